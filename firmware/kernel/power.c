/* power.c - the node's power budget (see power.h). */
#include "power.h"

#define PJ_PER_MJ 1000000000ull /* 1 mJ = 10^9 pJ */

void power_reset(struct power *power, uint32_t capacity_mj, uint32_t base_draw_uw)
{
    power->capacity_pj = (uint64_t)capacity_mj * PJ_PER_MJ;
    power->base_draw_uw = base_draw_uw;
    power->used_pj = 0;
    power->time_us = 0;
}

void power_advance(struct power *power, uint64_t now_us, uint64_t draw_uw)
{
    uint64_t left;
    uint64_t elapsed;

    if (now_us <= power->time_us) {
        return;
    }
    elapsed = now_us - power->time_us;
    power->time_us = now_us;
    left = power->capacity_pj - power->used_pj;
    /* draw_uw * elapsed would overflow only past 2^64 pJ, far beyond any capacity: check by
     * division so that a long pause still empties the battery instead of wrapping */
    if (draw_uw != 0 && elapsed > left / draw_uw) {
        power->used_pj = power->capacity_pj;
        return;
    }
    power->used_pj += draw_uw * elapsed;
}

void power_restart(struct power *power)
{
    power->time_us = 0;
}

uint32_t power_leftover_milli(const struct power *power)
{
    /* in nJ, so that x 100000 stays within 64 bits for capacities up to 1.8e8 J */
    const uint64_t capacity_nj = power->capacity_pj / 1000u;
    const uint64_t left_nj = (power->capacity_pj - power->used_pj) / 1000u;
    return capacity_nj == 0 ? 0 : (uint32_t)(left_nj * 100000u / capacity_nj);
}
