/*
 * sram.h - the kernel's SRAM allocator: first fit over the SRAM region in 8-byte aligned
 * blocks, as firmware_sim/core/sram.py. Instance areas (context, state, port buffers) and the
 * state-variable table's output variables live here.
 *
 * The bookkeeping is a table of allocated blocks in address order: the free blocks are the
 * gaps between them, so first fit with coalescing needs no free list at all.
 */
#ifndef KERNEL_SRAM_H
#define KERNEL_SRAM_H

#include <stdint.h>

#include "text.h"

void sram_reset(uint32_t base, uint32_t size);

/* The guest address of a new zero-filled block of at least `size` bytes (> 0), or 0 when no
 * free block is large enough (then `why` says how much was asked for, how much is free and the
 * largest free block, naming `owner`). */
uint32_t sram_allocate(uint32_t size, const char *owner, struct text *why);

/* Return a block; an address that is not one is ignored (nothing in the kernel frees twice). */
void sram_free(uint32_t address);

uint32_t sram_largest_free(void);
uint32_t sram_free_bytes(void);

#endif /* KERNEL_SRAM_H */
