/*
 * module_call.h - the one way the kernel runs module code: a method, or a module's init
 * subroutine, at a guest address with one argument.
 *
 * On RV32 the call is a direct call through the (relocated) method pointer. On the host, where
 * the kernel is tested, guest code cannot run: the tests register C functions as fakes at
 * guest addresses, and a fake reaches the kernel's services by calling kernel_service as the
 * board's trap handler would.
 *
 * A call can end early: a service refused its arguments (kernel_service_faulted), or the board
 * caught a memory fault, an illegal instruction or a watchdog in module code. The board's trap
 * handler then calls module_call_abort, which returns from module_call as a faulted call, with
 * the kernel's stack as it was when the call began.
 */
#ifndef KERNEL_MODULE_CALL_H
#define KERNEL_MODULE_CALL_H

#include <stdbool.h>
#include <stdint.h>

struct call_outcome {
    int32_t status; /* the method's a0, as a signed status */
    bool faulted;   /* stopped by module_call_abort: status means nothing */
};

/* Run the code at guest address `entry` with a0 = `argument` until it returns. */
struct call_outcome module_call(uint32_t entry, uint32_t argument);

/* End the running call as faulted; does not return. Only while module_call_running(). A trap
 * handler that calls it leaves the trap without mret: the board restores what the trap changed
 * (mstatus.MIE, the privilege) first. */
_Noreturn void module_call_abort(void);

bool module_call_running(void);

#if !defined(__riscv)
/* Host tests: the C function that stands for the guest code at `entry`; a call to an entry
 * with no fake faults, as a jump into memory holding no code would. */
typedef int32_t (*module_fake)(uint32_t argument);
void module_call_fake(uint32_t entry, module_fake fake);
void module_call_forget_fakes(void);
#endif

#endif /* KERNEL_MODULE_CALL_H */
