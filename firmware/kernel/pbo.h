/*
 * pbo.h - one PBO on the kernel (pbort/pbo.py's RegisteredPBO): its module, lifecycle state,
 * executor instance, port store, input bindings, job, counters, performance values and log.
 *
 * State changes go through one function, pbo_move, which runs the actions tied to states:
 * entering ON releases the job, leaving ON stops it, entering ERROR calls the module's error
 * method once and copies its outputs to the table, entering KILLED frees the executor.
 */
#ifndef KERNEL_PBO_H
#define KERNEL_PBO_H

#include <stdbool.h>
#include <stdint.h>

#include "area.h"
#include "instance.h"
#include "lifecycle.h"
#include "module.h"
#include "performance.h"
#include "scheduler.h"
#include "stats.h"
#include "text.h"

#define UNBOUND 0xFFu

/* The ports whose buffers a PBO's store holds. */
#define STORED (DIRECTIONS(DIRECTION_OUT) | DIRECTIONS(DIRECTION_CONST) | \
                DIRECTIONS(DIRECTION_RESOURCE))

/* The byte and 32-bit fields first, then the 8-byte aligned job and counters, ordered so that
 * hardly any padding comes between fields: the kernel's table holds KERNEL_MAX_PBOS of these. */
struct pbo {
    bool used;
    bool pending;  /* registered by its module, not yet admitted to the kernel (kernel.h) */
    uint8_t state; /* enum pbo_state */
    uint8_t flow;  /* its rank in the ties of a release (kernel_reorder) */
    uint32_t serial; /* registration order: listings, ties of the flow order, its log lines */
    uint32_t logged; /* lines its module logged: the number of the latest */
    struct module module;
    struct instance executor;
    /* One SRAM block holding a buffer for each OUT port (its variable in the state-variable
     * table) and each CONST and RESOURCE port (its configured value), so that both outlive
     * the executor, as in the Python kernel; laid out as area_packed(STORED) says. 0 when the
     * module has no such port. */
    uint32_t store;
    uint8_t sources[ABI_MAX_PORTS]; /* an IN port's variable (pbo_source), or UNBOUND */
    struct job job;
    struct counters counters;
    struct performance performance;
};

/* A failed lifecycle call (init, on, off, kill, clear) asked for by the caller, after the state
 * change: "PBO 'gain': on returned -1; now ERROR; it logged: gain: k is not configured". */
#define PBO_METHOD_FAILED (-100)

/* Run init/on/off/kill/clear as the table allows: 0, or a negative value with `why` filled
 * (the table's refusal, or PBO_METHOD_FAILED after the state change). */
int32_t pbo_control(struct pbo *pbo, enum method method, struct text *why);

/* The scheduler's job: inputs in, cycle, then the evaluator; outputs back to the table. */
void pbo_execute(struct pbo *pbo);
void pbo_complete(struct pbo *pbo);

/* The guest address of a port's buffer in the store (OUT, CONST, RESOURCE ports). */
uint32_t pbo_stored(const struct pbo *pbo, uint32_t port);

/* The PBO whose OUT port `*out` input `port` is bound to, or NULL when it is unbound. */
struct pbo *pbo_source(const struct pbo *pbo, uint32_t port, uint32_t *out);
/* Bind input `port` to OUT port `out` of `source`. */
void pbo_bind(struct pbo *pbo, uint32_t port, const struct pbo *source, uint32_t out);

#endif /* KERNEL_PBO_H */
