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

#include "instance.h"
#include "lifecycle.h"
#include "module.h"
#include "performance.h"
#include "scheduler.h"
#include "stats.h"
#include "text.h"

#define UNBOUND 0xFFu

struct pbo {
    bool used;
    bool pending; /* registered by its module, not yet admitted to the kernel (kernel.h) */
    uint32_t serial; /* registration order: listings, ties between jobs, its log lines */
    struct module module;
    enum pbo_state state;
    struct instance executor;
    /* One SRAM block holding a buffer for each OUT port (its variable in the state-variable
     * table) and each CONST and RESOURCE port (its configured value), so that both outlive
     * the executor, as in the Python kernel. 0 when the module has no such port. */
    uint32_t store;
    uint32_t store_offsets[ABI_MAX_PORTS];
    uint8_t source_pbo[ABI_MAX_PORTS];  /* an IN port's variable: the PBO's slot, or UNBOUND */
    uint8_t source_port[ABI_MAX_PORTS]; /* and its OUT port */
    struct job job;
    struct counters counters;
    struct performance performance;
    uint32_t logged; /* lines its module logged: the number of the latest */
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

#endif /* KERNEL_PBO_H */
