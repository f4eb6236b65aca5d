/* kernel_run.c - the main loop's side of the scheduler (kernel.h, "Running"): which due job
 * runs next, and running it with its counters and the power it drew. */
#include "kernel.h"

#include "kernel_internal.h"

uint64_t kernel_time_us(void)
{
    return kernel_now_us();
}

/* The due job released before `limit` that goes first: the lowest priority number, then the
 * data flow's order (flow_order.c). */
static struct pbo *first_due(uint64_t now, uint64_t limit)
{
    struct pbo *best = 0;
    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        struct pbo *pbo = &kernel.pbos[i];
        const struct job *job = &pbo->job;
        const bool due = job->pending && job->release_us <= now && job->release_us < limit;
        if (!kernel_admitted(pbo) || !due) {
            continue;
        }
        if (best == 0 || job->priority < best->job.priority ||
            (job->priority == best->job.priority && pbo->flow < best->flow)) {
            best = pbo;
        }
    }
    return best;
}

/* Run one job: its calls, its outputs to the table, its counters, the power it drew. */
static void dispatch(struct pbo *pbo)
{
    const uint64_t start = kernel_now_us();
    uint64_t finish;

    pbo_execute(pbo);
    finish = kernel_now_us();
    pbo_complete(pbo);
    scheduler_account(&pbo->job, &pbo->counters, &kernel.keeping, start, finish);
    kernel_account_power();
}

static bool run_before(uint64_t limit)
{
    struct pbo *pbo = first_due(kernel_now_us(), limit);
    if (pbo == 0) {
        return false;
    }
    dispatch(pbo);
    return true;
}

bool kernel_run_once(void)
{
    return run_before(UINT64_MAX);
}

bool kernel_next_release(uint64_t *when_us)
{
    bool found = false;
    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        const struct pbo *pbo = &kernel.pbos[i];
        const bool released = kernel_admitted(pbo) && pbo->job.pending;
        if (released && (!found || pbo->job.release_us < *when_us)) {
            *when_us = pbo->job.release_us;
            found = true;
        }
    }
    return found;
}

static void wait_until(uint64_t when_us)
{
    kernel.config.wait_until_us(when_us + kernel.epoch_us);
}

uint32_t kernel_run(uint64_t until_us, uint32_t cycles)
{
    uint32_t ran = 0;
    uint64_t next;

    while (ran < cycles) {
        if (run_before(until_us)) {
            ran++;
            continue;
        }
        if (kernel.config.wait_until_us == 0) {
            break;
        }
        if (!kernel_next_release(&next) || next >= until_us) {
            if (kernel_now_us() < until_us) {
                wait_until(until_us);
            }
            break;
        }
        wait_until(next);
    }
    return ran;
}
