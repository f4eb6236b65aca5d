/*
 * flash_layout.c - geometry, sector ownership and checked chip operations (flash_layout.h).
 */
#include "flash_layout.h"

#include "../board/board.h"
#include "../lib/crc.h"

/* What a sector is to the allocator. RETIRED: it held a module whose code ran, and this board
 * does not program code over code it ran before the node restarts (board_code_reusable). */
enum { FREE, TAKEN, RETIRED };
#define STATE_BITS 2u /* a sector's state, FREE to RETIRED */
#define STATES_A_BYTE (8u / STATE_BITS)
#define STATE_MASK ((1u << STATE_BITS) - 1u)

static struct {
    uint32_t base, size, sector, sectors, module_sectors, scratch;
    bool reusable; /* board_code_reusable(): a retired sector is free again at once */
    uint8_t used[MAX_SECTORS / STATES_A_BYTE]; /* each sector's state, packed */
} layout;

static unsigned state_of(uint32_t sector)
{
    unsigned shift = sector % STATES_A_BYTE * STATE_BITS;
    return layout.used[sector / STATES_A_BYTE] >> shift & STATE_MASK;
}

static void set_state(uint32_t sector, unsigned state)
{
    uint8_t *byte = &layout.used[sector / STATES_A_BYTE];
    unsigned shift = sector % STATES_A_BYTE * STATE_BITS;
    *byte = (uint8_t)((*byte & ~(STATE_MASK << shift)) | state << shift);
}

bool flash_layout_init(void)
{
    layout.base = board_flash_base();
    layout.size = board_flash_size();
    layout.sector = board_flash_sector_size();
    if (layout.sector < FLASH_BLOCK || layout.sector % FLASH_BLOCK || layout.size % layout.sector) {
        return false;
    }
    layout.sectors = layout.size / layout.sector;
    uint32_t directory_sector = (layout.size - 2 * FLASH_BLOCK) / layout.sector;
    if (layout.sectors > MAX_SECTORS || directory_sector < 2) {
        return false;
    }
    layout.scratch = directory_sector - 1;
    layout.module_sectors = layout.scratch;
    layout.reusable = board_code_reusable();
    for (uint32_t i = 0; i < MAX_SECTORS; i++) {
        set_state(i, i >= layout.module_sectors ? TAKEN : FREE);
    }
    return true;
}

uint32_t flash_base(void) { return layout.base; }
uint32_t flash_size(void) { return layout.size; }
uint32_t flash_sector_size(void) { return layout.sector; }
uint32_t flash_block_count(void) { return layout.size / FLASH_BLOCK; }
uint32_t flash_module_sectors(void) { return layout.module_sectors; }
uint32_t flash_scratch_offset(void) { return layout.scratch * layout.sector; }

uint32_t flash_slot_offset(unsigned slot)
{
    return layout.size - (2u - slot) * FLASH_BLOCK;
}

bool flash_slots_share_sector(void)
{
    return flash_sector_of(flash_slot_offset(0)) == flash_sector_of(flash_slot_offset(1));
}

uint32_t flash_sector_of(uint32_t offset)
{
    return offset / layout.sector;
}

uint32_t flash_sectors_for(uint32_t bytes)
{
    uint32_t count = bytes / layout.sector + (bytes % layout.sector != 0);
    return count ? count : 1;
}

/* The free run that starts at `first`: how many sectors long. */
static uint32_t run_at(uint32_t first)
{
    uint32_t end = first;
    while (end < layout.module_sectors && state_of(end) == FREE) {
        end++;
    }
    return end - first;
}

static void mark(const struct extent *extent, unsigned state)
{
    for (uint32_t i = 0; i < extent->count; i++) {
        set_state(extent->first + i, state);
    }
}

bool flash_allocate(uint32_t count, uint32_t most, struct extent *extent)
{
    struct extent best = {0, 0};
    for (uint32_t first = 0; first < layout.module_sectors;) {
        uint32_t run = run_at(first);
        if (count && run >= count) {
            best = (struct extent){first, count};
            break;
        }
        if (!count && run > best.count) {
            best = (struct extent){first, run};
        }
        first += run ? run : 1;
    }
    if (best.count == 0) {
        return false;
    }
    if (!count && most && best.count > most) {
        best.count = most;
    }
    mark(&best, TAKEN);
    *extent = best;
    return true;
}

bool flash_place(uint32_t first, uint32_t count, struct extent *extent)
{
    if (first >= layout.module_sectors || count > layout.module_sectors - first ||
        run_at(first) < count) {
        return false;
    }
    *extent = (struct extent){first, count};
    mark(extent, TAKEN);
    return true;
}

void flash_release(const struct extent *extent)
{
    mark(extent, FREE);
}

void flash_retire(const struct extent *extent)
{
    mark(extent, layout.reusable ? FREE : RETIRED);
}

void flash_shrink(struct extent *extent, uint32_t count)
{
    if (count >= extent->count) {
        return;
    }
    struct extent tail = {extent->first + count, extent->count - count};
    mark(&tail, FREE);
    extent->count = count;
}

uint32_t flash_largest_run(void)
{
    uint32_t largest = 0;
    for (uint32_t first = 0; first < layout.module_sectors;) {
        uint32_t run = run_at(first);
        largest = run > largest ? run : largest;
        first += run ? run : 1;
    }
    return largest;
}

uint32_t flash_free_sectors(void)
{
    uint32_t free = 0;
    for (uint32_t i = 0; i < layout.module_sectors; i++) {
        free += state_of(i) == FREE;
    }
    return free;
}

uint32_t flash_retired_sectors(void)
{
    uint32_t retired = 0;
    for (uint32_t i = 0; i < layout.module_sectors; i++) {
        retired += state_of(i) == RETIRED;
    }
    return retired;
}

bool flash_blank(uint32_t offset, size_t length)
{
    uint8_t chunk[64];
    while (length) {
        size_t piece = length < sizeof chunk ? length : sizeof chunk;
        board_flash_read(offset, chunk, piece);
        for (size_t i = 0; i < piece; i++) {
            if (chunk[i] != 0xFF) {
                return false;
            }
        }
        offset += piece;
        length -= piece;
    }
    return true;
}

bool flash_sector_blank(uint32_t sector)
{
    return flash_blank(sector * layout.sector, layout.sector);
}

bool flash_make_blank(uint32_t sector)
{
    return flash_sector_blank(sector) || board_flash_erase_sector(sector * layout.sector);
}

bool flash_program_block(uint32_t offset, const uint8_t *data, size_t length)
{
    uint8_t words[FLASH_BLOCK];
    if (length == 0 || length > FLASH_BLOCK) {
        return false;
    }
    size_t padded = (length + 3u) & ~(size_t)3u; /* an erased tail: NOR leaves 0xFF as it is */
    for (size_t i = 0; i < padded; i++) {
        words[i] = i < length ? data[i] : 0xFF;
    }
    return board_flash_program(offset, words, padded);
}

uint32_t flash_crc32(uint32_t offset, uint32_t length)
{
    uint8_t chunk[64];
    uint32_t crc = 0;
    while (length) {
        uint32_t piece = length < sizeof chunk ? length : (uint32_t)sizeof chunk;
        board_flash_read(offset, chunk, piece);
        crc = crc32_update(crc, chunk, piece);
        offset += piece;
        length -= piece;
    }
    return crc;
}
