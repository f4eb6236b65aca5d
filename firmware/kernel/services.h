/*
 * services.h - the kernel services a module reaches with ecall (firmware_sim/core/services.py
 * and the instance services of firmware_sim/core/guest.py).
 *
 * The board's trap handler passes a7 and a0..a3 to kernel_service (kernel.h) and puts the
 * result in a0. What a service accepts depends on what is running: a module's init subroutine
 * may REGISTER; a method may use its ports and report performance; both may read the time and
 * LOG. A bad argument (an unknown service, a context that is not the running method's own, a
 * port index out of range, a write to an IN or CONST port, a buffer the module could not use
 * itself, a LOG over 256 bytes, an unknown performance kind) is not returned as a status: it
 * faults the call, which puts the module into ERROR, and the fault text says what was expected
 * and what came.
 */
#ifndef KERNEL_SERVICES_H
#define KERNEL_SERVICES_H

#include <stdbool.h>
#include <stdint.h>

#include "instance.h"
#include "module.h"
#include "performance.h"

/* What runs now, for the services to check arguments against. */
struct call_scope {
    const struct module *module;     /* the method's module; NULL for an init subroutine */
    uint32_t owner;                  /* the PBO's slot, for its log */
    struct performance *performance; /* where reports go */
    uint32_t window;                 /* the context's address in the task window */
    const char *label;               /* "module 'gain' at 0x08000500 (executor)" */
};

/* A method or init subroutine starts / ended; a fault recorded in between is kept for
 * services_fault until the next services_enter. */
void services_enter(const struct call_scope *scope);
void services_leave(void);

/* The fault text of the call that ended (a service's refusal or the board's kernel_fault). */
const char *services_fault(void);

int32_t services_dispatch(uint32_t number, uint32_t a0, uint32_t a1, uint32_t a2, uint32_t a3);
bool services_faulted(void);
void services_record_fault(const char *text);

#endif /* KERNEL_SERVICES_H */
