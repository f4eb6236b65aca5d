/*
 * instance.h - one instance of a module (firmware_sim/core/guest.py's GuestInstance): an area
 * in SRAM and its method calls.
 *
 * Guests may not write SRAM. For a call the instance's area is copied to the end of the task
 * window with a fresh context whose pointers point there, the method runs with a0 = that
 * context, and the area is copied back (also after a fault: what the guest wrote stays
 * written). So ctx and its pointers are the same window addresses at every call, and on a
 * board whose memory protection lets module code write only the window and its stack, a
 * module writes only its own state and ports.
 */
#ifndef KERNEL_INSTANCE_H
#define KERNEL_INSTANCE_H

#include <stdbool.h>
#include <stdint.h>

#include "abi.h"
#include "module.h"
#include "performance.h"
#include "text.h"

enum role { ROLE_EXECUTOR, ROLE_ESTIMATOR };

struct instance {
    uint32_t area; /* guest address in SRAM; 0: no instance */
    uint8_t role;  /* enum role */
};

/* How one call went (pbort.code.CallResult): the status, or the fault that stopped it. */
struct call_result {
    int32_t status;
    bool faulted;
    uint64_t duration_us;
    char fault[FAILURE_TEXT]; /* "module 'gain' at 0x..., cycle: PORT_WRITE: ..." */
};

/* A new instance with a zero-filled area; false (and `why`) when SRAM has no room. */
bool instance_create(struct instance *instance, const struct module *module, enum role role,
                     struct text *why);
void instance_release(struct instance *instance);

/* Copy `port`'s value in from / out to `length` bytes at guest address `value`. */
void instance_put(const struct instance *instance, const struct module *module, uint32_t port,
                  uint32_t value);
void instance_get(const struct instance *instance, const struct module *module, uint32_t port,
                  uint32_t value);
/* Zero a port's buffer (an unbound input reads its port's zero value). */
void instance_zero(const struct instance *instance, const struct module *module, uint32_t port);

/*
 * Run `method` in the task window; an absent method returns 0 at once. Reports go to
 * `performance`, log lines to the PBO with slot `owner` (kernel.c).
 */
void instance_call(const struct instance *instance, const struct module *module, uint32_t owner,
                   struct performance *performance, enum method method,
                   struct call_result *result);

#endif /* KERNEL_INSTANCE_H */
