/*
 * timekeeping.h - whether the kernel keeps real time (pbort/timekeeping.py).
 *
 * A job's modelled schedule is what an ideal node would do: start at its release, or when the
 * CPU is free in the model, and run for its duration. Here the duration is the time the job's
 * calls took, so a job's *slip* is how much later than that it started: time the firmware spent
 * on something else (a transfer, a flash erase) while the job was due. Releases skipped because
 * of a slip are *missed releases*. A host must not read a module fault into measurements taken
 * while the node slipped.
 */
#ifndef KERNEL_TIMEKEEPING_H
#define KERNEL_TIMEKEEPING_H

#include <stdint.h>

#include "config.h"

#define SLIP_FLOOR_US 1000u /* slips below 1 ms count as on time, as in the Python kernel */

struct timekeeping {
    uint32_t missed;      /* releases skipped because jobs slipped, since the clock started */
    uint64_t worst_us;    /* the largest slip since the clock started */
    uint64_t free_us;     /* when the CPU is free in the model */
    uint32_t kept;        /* slips remembered, at most TIMEKEEPING_KEPT */
    uint32_t next;        /* where the next slip goes in the ring */
    uint64_t finish_us[TIMEKEEPING_KEPT];
    uint64_t slip_us[TIMEKEEPING_KEPT];
};

void timekeeping_restart(struct timekeeping *keeping);
/* A job released at `released` that took `duration` finished at `finish`: its slip (0: on
 * time), remembered. */
uint64_t timekeeping_job(struct timekeeping *keeping, uint64_t released, uint64_t duration,
                         uint64_t finish);
void timekeeping_skipped(struct timekeeping *keeping, uint32_t releases);
/* The largest slip of the remembered jobs that finished after `since` (0: none slipped). */
uint64_t timekeeping_worst_since(const struct timekeeping *keeping, uint64_t since);

#endif /* KERNEL_TIMEKEEPING_H */
