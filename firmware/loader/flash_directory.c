/*
 * flash_directory.c - the module directory (flash_directory.h).
 */
#include "flash_directory.h"

#include "../board/board.h"
#include "../lib/crc.h"
#include "flash_layout.h"

#define HEADER_SIZE 12
#define ENTRY_SIZE 48
#define ENTRY_SIZE_V1 44
#define KEPT_SIZE 20
#define ROOM (FLASH_BLOCK - HEADER_SIZE - 4)
#define VERSION 3
#define SCRATCH_SLOT 2

static struct {
    int newest_slot; /* 0, 1, or -1: none */
    uint32_t newest_sequence;
} directory = {-1, 0};

static void put16(uint8_t *p, uint32_t v) { p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); }

static void put32(uint8_t *p, uint32_t v)
{
    put16(p, v);
    put16(p + 2, v >> 16);
}

static uint32_t get16(const uint8_t *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8; }
static uint32_t get32(const uint8_t *p) { return get16(p) | get16(p + 2) << 16; }

/* A name as a record holds it: 1 to 16 ASCII characters, NUL-padded. */
static bool put_name(uint8_t *p, const char *name, struct text *why)
{
    size_t length = text_length(name, DIRECTORY_NAME_LEN + 1);
    bool ascii = true;
    for (size_t i = 0; i < length; i++) {
        ascii &= (uint8_t)name[i] < 0x80;
    }
    if (!length || length > DIRECTORY_NAME_LEN || !ascii) {
        text_format(why, "expected a module name of 1 to 16 ASCII characters, got %r", name,
                    (uint32_t)length);
        return false;
    }
    for (size_t i = 0; i < DIRECTORY_NAME_LEN; i++) {
        p[i] = i < length ? (uint8_t)name[i] : 0;
    }
    return true;
}

static void get_name(const uint8_t *p, char *name)
{
    size_t i = 0;
    for (; i < DIRECTORY_NAME_LEN && p[i]; i++) {
        name[i] = (char)p[i];
    }
    name[i] = '\0';
}

static void put_entry(uint8_t *p, const struct directory_entry *e)
{
    const uint32_t words[8] = {e->load_address, e->size,  e->link_base, e->init_address,
                               e->relocations,  e->crc32, e->sequence,  e->version};
    for (int i = 0; i < 8; i++) {
        put32(p + DIRECTORY_NAME_LEN + 4 * i, words[i]);
    }
}

static void get_entry(const uint8_t *p, struct directory_entry *e, bool has_version)
{
    get_name(p, e->name);
    p += DIRECTORY_NAME_LEN;
    e->load_address = get32(p);
    e->size = get32(p + 4);
    e->link_base = get32(p + 8);
    e->init_address = get32(p + 12);
    e->relocations = get32(p + 16);
    e->crc32 = get32(p + 20);
    e->sequence = get32(p + 24);
    e->version = has_version ? get32(p + 28) : 0;
}

static void too_many(const struct directory_record *record, struct text *why)
{
    text_format(why, "expected at most 5 modules in the directory (one 256-byte block), fewer "
                "with the versions it keeps of names no longer installed (20 bytes each), got %U",
                (uint64_t)record->entry_count);
    if (record->kept_count) {
        text_format(why, " and %U kept versions", (uint64_t)record->kept_count);
    }
}

bool directory_encode(const struct directory_record *record, uint8_t *block, uint32_t *length,
                      struct text *why)
{
    uint32_t size = record->entry_count * ENTRY_SIZE + record->kept_count * KEPT_SIZE;
    if (record->entry_count > DIRECTORY_MAX_ENTRIES || record->kept_count > DIRECTORY_MAX_KEPT ||
        size > ROOM) {
        too_many(record, why);
        return false;
    }
    for (uint32_t i = 0; i < FLASH_BLOCK; i++) {
        block[i] = 0xFF;
    }
    block[0] = 'R', block[1] = 'F', block[2] = 'M', block[3] = 'D';
    put16(block + 4, VERSION);
    block[6] = record->entry_count;
    block[7] = record->kept_count;
    put32(block + 8, record->sequence);
    uint8_t *p = block + HEADER_SIZE;
    for (int i = 0; i < record->entry_count; i++, p += ENTRY_SIZE) {
        if (!put_name(p, record->entries[i].name, why)) {
            return false;
        }
        put_entry(p, &record->entries[i]);
    }
    for (int i = 0; i < record->kept_count; i++, p += KEPT_SIZE) {
        if (!put_name(p, record->kept[i].name, why)) {
            return false;
        }
        put32(p + DIRECTORY_NAME_LEN, record->kept[i].version);
    }
    put32(p, crc32_update(0, block, (size_t)(p - block)));
    *length = (uint32_t)(p - block) + 4;
    return true;
}

static bool bad_header(const uint8_t *block, struct text *why)
{
    uint32_t version = get16(block + 4);
    bool magic = block[0] == 'R' && block[1] == 'F' && block[2] == 'M' && block[3] == 'D';
    if (magic && version >= 1 && version <= VERSION) {
        return false;
    }
    text_add(why, "expected magic b'RFMD' version 1 to 3, got ");
    text_add_bytes_repr(why, block, 4);
    text_format(why, " version %U", (uint64_t)version);
    return true;
}

bool directory_decode(const uint8_t *block, struct directory_record *record, struct text *why)
{
    if (bad_header(block, why)) {
        return false;
    }
    uint32_t version = get16(block + 4);
    uint32_t count = version == VERSION ? block[6] : get16(block + 6);
    uint32_t kept = version == VERSION ? block[7] : 0;
    uint32_t entry_size = version == 1 ? ENTRY_SIZE_V1 : ENTRY_SIZE;
    record->sequence = get32(block + 8);
    if (count * entry_size + kept * KEPT_SIZE > ROOM || count > DIRECTORY_MAX_ENTRIES) {
        text_format(why, "expected at most 240 bytes of entries, got %U entries and %U kept "
                    "versions", (uint64_t)count, (uint64_t)kept);
        return false;
    }
    uint32_t end = HEADER_SIZE + count * entry_size + kept * KEPT_SIZE;
    uint32_t computed = crc32_update(0, block, end);
    if (get32(block + end) != computed) {
        text_format(why, "expected CRC-32 %a of the %U-entry record (sequence %U), got %a",
                    (uint32_t)computed, (uint64_t)count, (uint64_t)record->sequence,
                    (uint32_t)(get32(block + end)));
        return false;
    }
    record->entry_count = (uint8_t)count;
    record->kept_count = (uint8_t)kept;
    for (uint32_t i = 0; i < count; i++) {
        get_entry(block + HEADER_SIZE + i * entry_size, &record->entries[i], version != 1);
    }
    const uint8_t *p = block + HEADER_SIZE + count * entry_size;
    for (uint32_t i = 0; i < kept; i++, p += KEPT_SIZE) {
        get_name(p, record->kept[i].name);
        record->kept[i].version = get32(p + DIRECTORY_NAME_LEN);
    }
    return true;
}

static uint32_t slot_offset(int slot)
{
    return slot == SCRATCH_SLOT ? flash_scratch_offset() : flash_slot_offset((unsigned)slot);
}

/* The record slot `slot` holds: 1 valid, 0 erased, -1 neither (`why` says what). */
static int read_slot(int slot, struct directory_record *record, struct text *why)
{
    uint8_t block[FLASH_BLOCK];
    board_flash_read(slot_offset(slot), block, FLASH_BLOCK);
    bool erased = true;
    for (uint32_t i = 0; i < FLASH_BLOCK; i++) {
        erased &= block[i] == 0xFF;
    }
    if (erased) {
        return 0;
    }
    return directory_decode(block, record, why) ? 1 : -1;
}

/* noinline: its line is not on the stack while the next slot is read and decoded. */
__attribute__((noinline)) static void report_slot(int slot, const char *reason,
                                                  void (*report)(const char *))
{
    char line[200];
    struct text text;
    text_start(&text, line, sizeof line);
    text_format(&text, "directory slot %U at %a ignored: %s", (uint64_t)slot,
                (uint32_t)(flash_base() + slot_offset(slot)), reason);
    report(line);
}

/* Program `record`'s bytes into slot `slot`, whose block must be erased. */
static bool program_slot(int slot, const uint8_t *bytes, uint32_t length)
{
    return flash_program_block(slot_offset(slot), bytes, length);
}

/* Put the record found in the scratch sector back into slot 0: erase the directory's sector
 * (the scratch copy stays meanwhile), program the slot. noinline: its block is not on the
 * stack while the slots are read. */
__attribute__((noinline)) static bool restore_from_scratch(const struct directory_record *record)
{
    uint8_t block[FLASH_BLOCK];
    uint32_t length;
    char unused[8];
    struct text why;
    text_start(&why, unused, sizeof unused);
    if (!directory_encode(record, block, &length, &why)) {
        return false;
    }
    uint32_t sector = flash_sector_of(flash_slot_offset(0));
    return board_flash_erase_sector(sector * flash_sector_size()) &&
           program_slot(0, block, length);
}

bool directory_load(struct directory_record *newest, void (*report)(const char *line))
{
    struct directory_record candidate;
    directory.newest_slot = -1;
    for (int slot = 0; slot < SCRATCH_SLOT; slot++) {
        char reason[160];
        struct text why;
        text_start(&why, reason, sizeof reason);
        int found = read_slot(slot, &candidate, &why);
        if (found < 0) {
            report_slot(slot, reason, report);
        }
        if (found > 0 && (directory.newest_slot < 0 || candidate.sequence > newest->sequence)) {
            *newest = candidate;
            directory.newest_slot = slot;
        }
    }
    char ignored[8];
    struct text quiet;
    text_start(&quiet, ignored, sizeof ignored);
    bool newer = read_slot(SCRATCH_SLOT, &candidate, &quiet) > 0 &&
                 (directory.newest_slot < 0 || candidate.sequence > newest->sequence);
    if (newer && restore_from_scratch(&candidate)) {
        *newest = candidate;
        directory.newest_slot = 0;
        report("directory: the newest record was in the scratch sector, put back into slot 0");
    }
    directory.newest_sequence = directory.newest_slot < 0 ? 0 : newest->sequence;
    return directory.newest_slot >= 0;
}

uint32_t directory_next_sequence(void)
{
    return directory.newest_sequence + 1;
}

/* Write into a slot whose sector holds the other slot: scratch copy first, then the sector. */
static bool write_through_scratch(int slot, const uint8_t *bytes, uint32_t length)
{
    uint32_t scratch = flash_scratch_offset();
    uint32_t sector = flash_sector_of(flash_slot_offset(0)) * flash_sector_size();
    return flash_make_blank(flash_sector_of(scratch)) &&
           program_slot(SCRATCH_SLOT, bytes, length) && board_flash_erase_sector(sector) &&
           program_slot(slot, bytes, length);
}

bool directory_write(const struct directory_record *record, struct text *why)
{
    uint8_t block[FLASH_BLOCK];
    uint32_t length;
    if (!directory_encode(record, block, &length, why)) {
        return false;
    }
    int slot = directory.newest_slot < 0 ? 0 : 1 - directory.newest_slot;
    uint32_t offset = flash_slot_offset((unsigned)slot);
    bool written;
    if (flash_blank(offset, FLASH_BLOCK)) {
        written = program_slot(slot, block, length);
    } else if (flash_slots_share_sector()) {
        written = write_through_scratch(slot, block, length);
    } else {
        written = board_flash_erase_sector(flash_sector_of(offset) * flash_sector_size()) &&
                  program_slot(slot, block, length);
    }
    if (!written) {
        text_format(why, "the flash refused the directory write at %a",
                    (uint32_t)(flash_base() + offset));
        return false;
    }
    directory.newest_slot = slot;
    directory.newest_sequence = record->sequence;
    return true;
}
