/*
 * area.h - an instance's area: the 36-byte context, then the state, then each port buffer,
 * every part 8-byte aligned (firmware_sim/core/guest.py, AreaLayout).
 *
 * The offsets follow from the module's ports, so the kernel computes them when it needs them
 * instead of keeping them per PBO: a sum over at most 8 ports costs less than the RAM.
 */
#ifndef KERNEL_AREA_H
#define KERNEL_AREA_H

#include <stdint.h>

#include "module.h"

#define AREA_ALIGNMENT 8u

/* Port directions as bits, to pick the ports a block holds (area_packed). */
#define DIRECTIONS(direction) (1u << (direction))
#define ALL_DIRECTIONS 0xFu

/* `value` rounded up to a multiple of 8, in 64 bits: descriptor sizes may be absurd. */
uint64_t area_align(uint64_t value);

/* The area size `module`'s descriptor asks for (64-bit: a 4 x 65535 x 65535 frame does not fit
 * 32 bits); sets module->area_size when it is at most `limit` bytes. */
uint64_t area_plan(struct module *module, uint32_t limit);

/*
 * Where `port`'s buffer starts in a block that holds, in port order and each 8-byte aligned,
 * the buffers of the ports whose direction is in `directions` (DIRECTIONS bits); with `port`
 * = port_count, the block's size. For a module whose area fits.
 */
uint32_t area_packed(const struct module *module, uint32_t port, uint32_t directions);

/* The offset of `port`'s buffer from the start of an instance's area. */
uint32_t area_port(const struct module *module, uint32_t port);

/* Write `struct pbo_context` for an area at guest address `base`: NULL for no state and for
 * unused ports. */
void area_write_context(const struct module *module, uint32_t base);

#endif /* KERNEL_AREA_H */
