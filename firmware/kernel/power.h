/*
 * power.h - the node's power budget, the paper's non-functional metric
 * (firmware_sim/core/power.py).
 *
 * A node has an energy capacity (a battery) and a base draw. Each running PBO adds the draw its
 * evaluator reports (non-functional value 0, in thousandths of a mW, i.e. µW). Integrating the
 * draws over the kernel's time gives the energy used, and the "leftover power" on a 0-100 scale
 * that the paper compares with a threshold (20 in its experiment). Integers only: energy in
 * picojoules (µW x µs), so 3600 J fits 64 bits with room to spare and no soft float is linked.
 */
#ifndef KERNEL_POWER_H
#define KERNEL_POWER_H

#include <stdint.h>

struct power {
    uint64_t capacity_pj;
    uint32_t base_draw_uw;
    uint64_t used_pj;
    uint64_t time_us; /* the kernel time the energy is accounted to */
};

void power_reset(struct power *power, uint32_t capacity_mj, uint32_t base_draw_uw);
/* Account the energy drawn from the last call until `now_us` at `draw_uw` in all (base draw
 * included); a time before the last one is ignored (the clock restarted: see power_restart). */
void power_advance(struct power *power, uint64_t now_us, uint64_t draw_uw);
/* The clock starts again from 0: account from there (what was drawn stays drawn). */
void power_restart(struct power *power);
/* Energy left on the paper's 0-100 scale, in thousandths (100000 = full). */
uint32_t power_leftover_milli(const struct power *power);

#endif /* KERNEL_POWER_H */
