/*
 * module_call.c - running module code (see module_call.h).
 *
 * Both builds leave a call early the same way: a jump back to the point module_call saved,
 * which returns the call as faulted. On the host that is setjmp/longjmp; the freestanding RV32
 * build has no libc, so it saves and restores the callee-saved registers, sp and ra itself.
 */
#include "module_call.h"

#if defined(__riscv)

/* ra, sp, s0..s11: what a call preserves, so what a jump back must restore. */
typedef module_jump_point jump_point;

__asm__(".text\n"
        ".globl module_call_save\n"
        "module_call_save:\n"
        "  sw ra, 0(a0)\n  sw sp, 4(a0)\n"
        "  sw s0, 8(a0)\n  sw s1, 12(a0)\n  sw s2, 16(a0)\n  sw s3, 20(a0)\n"
        "  sw s4, 24(a0)\n  sw s5, 28(a0)\n  sw s6, 32(a0)\n  sw s7, 36(a0)\n"
        "  sw s8, 40(a0)\n  sw s9, 44(a0)\n  sw s10, 48(a0)\n  sw s11, 52(a0)\n"
        "  li a0, 0\n  ret\n"
        ".globl module_call_jump\n"
        "module_call_jump:\n"
        "  lw ra, 0(a0)\n  lw sp, 4(a0)\n"
        "  lw s0, 8(a0)\n  lw s1, 12(a0)\n  lw s2, 16(a0)\n  lw s3, 20(a0)\n"
        "  lw s4, 24(a0)\n  lw s5, 28(a0)\n  lw s6, 32(a0)\n  lw s7, 36(a0)\n"
        "  lw s8, 40(a0)\n  lw s9, 44(a0)\n  lw s10, 48(a0)\n  lw s11, 52(a0)\n"
        "  li a0, 1\n  ret\n");

#define SAVE(point) module_call_save(point)
#define JUMP(point) module_call_jump(point)

typedef int32_t (*guest_code)(uint32_t argument);

static module_runner runner;

void module_call_use(module_runner board_runner)
{
    runner = board_runner;
}

static int32_t run(uint32_t entry, uint32_t argument)
{
    if (runner != 0) {
        return runner(entry, argument);
    }
    /* The loader fixed the pointer (record 07) or named the init subroutine (record 08): the
     * address is where the code is. */
    return ((guest_code)(uintptr_t)entry)(argument);
}

#else /* the host: fakes */

#include <setjmp.h>

typedef jmp_buf jump_point;

#define SAVE(point) setjmp(point)
#define JUMP(point) longjmp(point, 1)
#define MAX_FAKES 64u

static struct {
    uint32_t entry;
    module_fake fake;
} fakes[MAX_FAKES];

void module_call_fake(uint32_t entry, module_fake fake)
{
    for (uint32_t i = 0; i < MAX_FAKES; i++) {
        if (fakes[i].entry == entry || fakes[i].fake == 0) {
            fakes[i].entry = entry;
            fakes[i].fake = fake;
            return;
        }
    }
}

void module_call_forget_fakes(void)
{
    for (uint32_t i = 0; i < MAX_FAKES; i++) {
        fakes[i].entry = 0;
        fakes[i].fake = 0;
    }
}

static int32_t run(uint32_t entry, uint32_t argument)
{
    for (uint32_t i = 0; i < MAX_FAKES && fakes[i].fake != 0; i++) {
        if (fakes[i].entry == entry) {
            return fakes[i].fake(argument);
        }
    }
    module_call_abort(); /* no code there */
}

#endif

static jump_point caller;
static volatile bool running; /* volatile: read after a jump back into module_call */

struct call_outcome module_call(uint32_t entry, uint32_t argument)
{
    struct call_outcome outcome = {0, true};

    if (SAVE(caller) != 0) {
        running = false; /* back from module_call_abort */
        return outcome;
    }
    running = true;
    outcome.status = run(entry, argument);
    outcome.faulted = false;
    running = false;
    return outcome;
}

_Noreturn void module_call_abort(void)
{
    JUMP(caller);
}

bool module_call_running(void)
{
    return running;
}
