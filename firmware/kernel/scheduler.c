/* scheduler.c - releases on a grid and the per-job accounting (see scheduler.h). */
#include "scheduler.h"

#define SECOND_US 1000000ull
#define REBASE_US (MILLIHERTZ_US) /* m periods of 10^9/m µs: exactly 1000 s */

uint64_t job_release(const struct job *job, uint64_t index)
{
    const uint64_t m = job->millihertz;
    /* split so that no product passes 10^17: (index % m) x 10^9 < m x 10^9 <= 10^17 */
    return job->phase_us + index / m * REBASE_US + index % m * MILLIHERTZ_US / m;
}

/* The first grid point at or after `time`: k = ceil((time - phase) x m / 10^9), split as
 * job_release is. */
static uint64_t first_at_or_after(const struct job *job, uint64_t time)
{
    const uint64_t m = job->millihertz;
    uint64_t since;

    if (time <= job->phase_us) {
        return 0;
    }
    since = time - job->phase_us;
    return since / REBASE_US * m + (since % REBASE_US * m + MILLIHERTZ_US - 1u) / MILLIHERTZ_US;
}

/* Move the grid's origin forward by whole multiples of 1000 s: the same grid, smaller k. */
static void rebase(struct job *job)
{
    const uint64_t whole = job->index / job->millihertz;
    job->phase_us += whole * REBASE_US;
    job->index -= whole * job->millihertz;
}

static void release_at(struct job *job, uint64_t index)
{
    job->index = index;
    rebase(job);
    job->release_us = job_release(job, job->index);
    job->pending = true;
}

/* Released now, then on the grid from the clock's zero (scheduler.h): the index is the last
 * grid point at or before now, so that the next release is the first after it. */
void scheduler_start(struct job *job, uint64_t now)
{
    job->active = true;
    job->phase_us = now / REBASE_US * REBASE_US;
    job->index = first_at_or_after(job, now + 1u) - 1u;
    rebase(job);
    job->release_us = now;
    job->pending = true;
}

void scheduler_stop(struct job *job)
{
    job->active = false;
    job->pending = false;
}

/* Held the CPU longer than its period: (finish - start) > 10^9 / m, without dividing. */
static bool is_long(const struct job *job, uint64_t held)
{
    return held > REBASE_US || held * job->millihertz > MILLIHERTZ_US;
}

void scheduler_account(struct job *job, struct counters *counters, struct timekeeping *keeping,
                       uint64_t start, uint64_t finish)
{
    const uint64_t released = job->release_us;
    const uint64_t slip = timekeeping_job(keeping, released, finish - start, finish);
    uint64_t next = job->index + 1u;
    uint64_t first_free;

    counters->cycles++;
    counters->busy_time_us += finish - start;
    if (is_long(job, finish - start)) {
        counters->long_jobs++; /* its own fault, unlike the releases others made it skip */
    }
    if (finish > job_release(job, next)) {
        counters->missed_deadlines++;
    }
    job->pending = false;
    if (!job->active) {
        return; /* the job switched itself off (it failed into ERROR) */
    }
    first_free = first_at_or_after(job, finish);
    if (first_free > next) {
        counters->overruns += (uint32_t)(first_free - next);
        if (slip != 0) {
            const uint64_t modelled = first_at_or_after(job, finish - slip);
            timekeeping_skipped(keeping, (uint32_t)(first_free - (modelled > next ? modelled
                                                                                  : next)));
        }
        next = first_free;
    }
    release_at(job, next);
}
