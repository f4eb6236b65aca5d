/* sram.c - first-fit allocation in SRAM (see sram.h). */
#include "sram.h"

#include "area.h"
#include "config.h"
#include "guest_memory.h"

struct block {
    uint32_t address;
    uint32_t size; /* rounded up to 8 */
};

static struct {
    uint32_t base;
    uint32_t size;
    uint32_t count;
    struct block blocks[SRAM_MAX_BLOCKS]; /* allocated, in address order */
} sram;

void sram_reset(uint32_t base, uint32_t size)
{
    sram.base = base;
    sram.size = size;
    sram.count = 0;
}

/* The free gap before block `index` (index == count: the gap after the last block). */
static uint32_t gap_start(uint32_t index)
{
    return index == 0 ? sram.base : sram.blocks[index - 1].address + sram.blocks[index - 1].size;
}

static uint32_t gap_size(uint32_t index)
{
    const uint32_t end = index == sram.count ? sram.base + sram.size : sram.blocks[index].address;
    return end - gap_start(index);
}

uint32_t sram_largest_free(void)
{
    uint32_t largest = 0;
    for (uint32_t i = 0; i <= sram.count; i++) {
        largest = gap_size(i) > largest ? gap_size(i) : largest;
    }
    return largest;
}

uint32_t sram_free_bytes(void)
{
    uint32_t free = 0;
    for (uint32_t i = 0; i <= sram.count; i++) {
        free += gap_size(i);
    }
    return free;
}

static void refuse(struct text *why, uint32_t size, uint64_t rounded, const char *owner)
{
    text_format(why, "out of SRAM: %s requested %u bytes (%U aligned), but only %u of %u bytes "
                     "are free and the largest free block is %u bytes",
                owner, size, rounded, sram_free_bytes(), sram.size, sram_largest_free());
    if (sram.count == SRAM_MAX_BLOCKS) {
        text_format(why, " (the kernel's table of %u blocks is full)", SRAM_MAX_BLOCKS);
    }
}

static uint32_t take(uint32_t index, uint32_t size)
{
    const uint32_t address = gap_start(index);
    for (uint32_t i = sram.count; i > index; i--) {
        sram.blocks[i] = sram.blocks[i - 1];
    }
    sram.blocks[index].address = address;
    sram.blocks[index].size = size;
    sram.count++;
    bytes_zero(guest_bytes(address, size), size);
    return address;
}

uint32_t sram_allocate(uint32_t size, const char *owner, struct text *why)
{
    const uint64_t rounded = area_align(size);

    if (sram.count < SRAM_MAX_BLOCKS) {
        for (uint32_t i = 0; i <= sram.count; i++) {
            if (gap_size(i) >= rounded) {
                return take(i, (uint32_t)rounded);
            }
        }
    }
    refuse(why, size, rounded, owner);
    return 0;
}

void sram_free(uint32_t address)
{
    for (uint32_t i = 0; i < sram.count; i++) {
        if (sram.blocks[i].address == address) {
            sram.count--;
            for (uint32_t j = i; j < sram.count; j++) {
                sram.blocks[j] = sram.blocks[j + 1];
            }
            return;
        }
    }
}
