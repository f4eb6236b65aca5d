/* timekeeping.c - the slip of the kernel's jobs (see timekeeping.h). */
#include "timekeeping.h"

void timekeeping_restart(struct timekeeping *keeping)
{
    keeping->missed = 0;
    keeping->worst_us = 0;
    keeping->free_us = 0;
    keeping->kept = 0;
    keeping->next = 0;
}

uint64_t timekeeping_job(struct timekeeping *keeping, uint64_t released, uint64_t duration,
                         uint64_t finish)
{
    const uint64_t start = released > keeping->free_us ? released : keeping->free_us;
    const uint64_t modelled = start + duration;
    const uint64_t slip = finish > modelled ? finish - modelled : 0;

    keeping->free_us = modelled;
    if (slip < SLIP_FLOOR_US) {
        return 0;
    }
    keeping->finish_us[keeping->next] = finish;
    keeping->slip_us[keeping->next] = slip;
    keeping->next = (keeping->next + 1u) % TIMEKEEPING_KEPT;
    keeping->kept += keeping->kept < TIMEKEEPING_KEPT ? 1u : 0u;
    keeping->worst_us = slip > keeping->worst_us ? slip : keeping->worst_us;
    return slip;
}

void timekeeping_skipped(struct timekeeping *keeping, uint32_t releases)
{
    keeping->missed += releases;
}

uint64_t timekeeping_worst_since(const struct timekeeping *keeping, uint64_t since)
{
    uint64_t worst = 0;
    for (uint32_t i = 0; i < keeping->kept; i++) {
        if (keeping->finish_us[i] > since && keeping->slip_us[i] > worst) {
            worst = keeping->slip_us[i];
        }
    }
    return worst;
}
