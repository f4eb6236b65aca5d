/*
 * scheduler.h - one CPU, cooperative and non-preemptive, on the board's microsecond clock
 * (pbort/scheduler.py).
 *
 * A periodic PBO is released at once when it is switched on, then on its period's grid counted
 * from the clock's zero, k x period, as in pbort/scheduler.py: PBOs of one rate release together
 * whenever each was switched on, so a pipeline's latency does not depend on the moments of the
 * host's START requests. When the CPU is free, the due job with the lowest priority number
 * runs, ties going by the data flow (flow_order.c); a job runs to completion. A job's deadline is
 * its next release. A release that comes while the previous job has not started or not
 * finished is skipped and counted as an overrun: the scheduler never queues a backlog, it
 * resumes at the first grid point after the late job finished.
 *
 * Rates are in millihertz (0.01 Hz to 100 kHz as a host may ask, RATE): integers keep the grid
 * exact without floating point, which RV32IM would do in soft float. A release time is
 * phase + floor(k x 10^9 / mHz) µs, and the phase moves forward by 1000 s every mHz periods, so
 * k x 10^9 stays far from overflowing 64 bits however long the node runs.
 */
#ifndef KERNEL_SCHEDULER_H
#define KERNEL_SCHEDULER_H

#include <stdbool.h>
#include <stdint.h>

#include "stats.h"
#include "timekeeping.h"

#define MILLIHERTZ_US 1000000000ull /* µs x mHz in one second-squared: period = this / mHz */

struct job {
    uint32_t millihertz; /* its rate */
    int32_t priority;    /* lower runs first */
    bool active;         /* switched on: released on its grid */
    bool pending;        /* a release waits at `release_us` */
    uint64_t release_us;
    uint64_t phase_us; /* the grid's origin */
    uint64_t index;    /* the grid point of the pending release */
};

/* The grid point `index` of a job. */
uint64_t job_release(const struct job *job, uint64_t index);

/* Switched on at `now`: released now, then on its grid. */
void scheduler_start(struct job *job, uint64_t now);
/* Switched off: a pending release is dropped. */
void scheduler_stop(struct job *job);

/*
 * After a job released at `released` ran from `start` to `finish`: count it, its busy time,
 * a long job, a missed deadline and skipped releases (those a slip made it skip also as missed
 * releases in `keeping`), then release it again on its grid.
 */
void scheduler_account(struct job *job, struct counters *counters, struct timekeeping *keeping,
                       uint64_t start, uint64_t finish);

#endif /* KERNEL_SCHEDULER_H */
