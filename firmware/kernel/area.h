/*
 * area.h - an instance's area: the 36-byte context, then the state, then each port buffer,
 * every part 8-byte aligned (firmware_sim/core/guest.py, AreaLayout).
 */
#ifndef KERNEL_AREA_H
#define KERNEL_AREA_H

#include <stdint.h>

#include "module.h"

#define AREA_ALIGNMENT 8u

/* `value` rounded up to a multiple of 8, in 64 bits: descriptor sizes may be absurd. */
uint64_t area_align(uint64_t value);

/* The area size `module`'s descriptor asks for (64-bit: a 4 x 65535 x 65535 frame does not fit
 * 32 bits); fills module->layout and each port's size when it is at most `limit` bytes. */
uint64_t area_plan(struct module *module, uint32_t limit);

/* Write `struct pbo_context` for an area at guest address `base`: NULL for no state and for
 * unused ports. */
void area_write_context(const struct module *module, uint32_t base);

#endif /* KERNEL_AREA_H */
