/*
 * module_call.h - the one way the kernel runs module code: a method, or a module's init
 * subroutine, at a guest address with one argument.
 *
 * On RV32 the board runs the code (module_call_use): the firmware in user mode on the module
 * stack, with its memory guarded and a watchdog (firmware/rv32/trap.c); without a runner it is
 * a direct call through the (relocated) method pointer. On the host, where
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

#if defined(__riscv)
/* The board's way to run module code: `entry` with a0 = `argument`, returning its a0, or
 * ending through module_call_abort. Set once at boot; NULL: a direct call. */
typedef int32_t (*module_runner)(uint32_t entry, uint32_t argument);
void module_call_use(module_runner runner);

/* A point to come back to: ra, sp and s0..s11. save returns 0, then 1 when jumped to. The
 * board's runner returns through one from its trap handler when module code returns. */
typedef uint32_t module_jump_point[14];
int module_call_save(module_jump_point point) __attribute__((returns_twice));
_Noreturn void module_call_jump(module_jump_point point);
#endif

#if !defined(__riscv)
/* Host tests: the C function that stands for the guest code at `entry`; a call to an entry
 * with no fake faults, as a jump into memory holding no code would. */
typedef int32_t (*module_fake)(uint32_t argument);
void module_call_fake(uint32_t entry, module_fake fake);
void module_call_forget_fakes(void);
#endif

#endif /* KERNEL_MODULE_CALL_H */
