/*
 * flash_layout.h - the node's flash as the Python node lays it out, on a chip that erases
 * whole sectors.
 *
 * The Python node's flash is 256-byte blocks, each erased on its own, with the module
 * directory in the last two blocks. QEMU's CFI flash (like most NOR) erases only 256 KiB
 * sectors, so this layer keeps the same block layout and the same directory bytes, and adds
 * the one rule that makes sectors safe: a sector is erased only when nothing in it must be kept.
 *
 *   sectors 0 .. scratch-1   modules: a module or a transfer owns whole sectors, so erasing
 *                            what it wrote never touches another module
 *   sector scratch           a copy of the next directory record while the directory's own
 *                            sector is erased (flash_directory.c), so a power cut then loses
 *                            nothing
 *   last two blocks          the directory's two slots, exactly where the Python node keeps them
 *
 * Block numbers, load addresses and every byte of a directory record are the Python node's;
 * only where a module may start (a sector boundary) is this layer's choice.
 */
#ifndef NODE_FLASH_LAYOUT_H
#define NODE_FLASH_LAYOUT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define FLASH_BLOCK 256u
#define MAX_SECTORS 512u

struct extent {
    uint32_t first; /* sector */
    uint32_t count; /* sectors; 0: none */
};

/* Read the board's geometry and mark every module sector free; false when the flash is too
 * small or has too many sectors for this build. */
bool flash_layout_init(void);

uint32_t flash_base(void);
uint32_t flash_size(void);
uint32_t flash_sector_size(void);
uint32_t flash_block_count(void);
uint32_t flash_module_sectors(void);          /* sectors modules may own */
uint32_t flash_scratch_offset(void);          /* the scratch sector's first byte */
uint32_t flash_slot_offset(unsigned slot);    /* directory slot 0 or 1 */
bool flash_slots_share_sector(void);
uint32_t flash_sector_of(uint32_t offset);
uint32_t flash_sectors_for(uint32_t bytes);   /* at least 1 */

/* Sector ownership: first fit of `count` sectors (0: the largest free run, at most `most`),
 * an exact place, giving back. False when there is no room (see flash_largest_run). */
bool flash_allocate(uint32_t count, uint32_t most, struct extent *extent);
bool flash_place(uint32_t first, uint32_t count, struct extent *extent);
void flash_release(const struct extent *extent);
/* Give back sectors that held a module whose code ran: on a board that does not program code
 * over code it ran (board_code_reusable false: QEMU keeps its translations of the old code),
 * they stay out of use, retired, until the node restarts. */
void flash_retire(const struct extent *extent);
void flash_shrink(struct extent *extent, uint32_t count);
uint32_t flash_largest_run(void);
uint32_t flash_free_sectors(void);
uint32_t flash_retired_sectors(void);

/* Chip operations with the layer's checks: a sector erased only if not blank already, a
 * block programmed only on erased words (the board refuses otherwise). */
bool flash_sector_blank(uint32_t sector);
bool flash_make_blank(uint32_t sector);
bool flash_program_block(uint32_t offset, const uint8_t *data, size_t length);
bool flash_blank(uint32_t offset, size_t length);
/* CRC-32 of `length` bytes of flash at `offset`. */
uint32_t flash_crc32(uint32_t offset, uint32_t length);

#endif
