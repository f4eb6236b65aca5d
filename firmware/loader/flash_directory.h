/*
 * flash_directory.h - which committed modules the flash holds, safe from power cuts, in the
 * Python node's exact bytes (firmware_sim/core/flash_directory.py, docs/node.md).
 *
 * Two slots, the last two flash blocks; each a record: "RFMD", version 3 (u16), entry count
 * (u8), kept-version count (u8), sequence (u32), 48-byte entries, 20-byte kept versions, CRC-32
 * of all of it; little-endian. A commit writes the slot that does not hold the newest record,
 * with the next sequence; boot takes the valid record with the highest sequence. Versions 1 and
 * 2 of the record are read too, as the Python node reads them.
 *
 * Both slots sit in one erase sector here, so writing over a used slot would erase the newest
 * record with it. Then the record goes first to the scratch sector, the directory's sector is
 * erased and the record programmed into its slot; boot also looks at the scratch copy and puts a
 * newer one back. At every moment one valid record holds the newest committed state.
 */
#ifndef NODE_FLASH_DIRECTORY_H
#define NODE_FLASH_DIRECTORY_H

#include <stdbool.h>
#include <stdint.h>

#include "../kernel/text.h"

#define DIRECTORY_NAME_LEN 16
#define DIRECTORY_MAX_ENTRIES 5 /* (256 - 12 - 4) / 48 */
#define DIRECTORY_MAX_KEPT 12   /* (256 - 12 - 4) / 20 */

struct directory_entry {
    char name[DIRECTORY_NAME_LEN + 1];
    uint32_t load_address, size, link_base, init_address, relocations, crc32, sequence, version;
};

struct kept_version {
    char name[DIRECTORY_NAME_LEN + 1];
    uint32_t version; /* major << 24 | minor << 16 | revision */
};

struct directory_record {
    uint32_t sequence;
    uint8_t entry_count, kept_count;
    struct directory_entry entries[DIRECTORY_MAX_ENTRIES + 1]; /* one more: refused, not overrun */
    struct kept_version kept[DIRECTORY_MAX_KEPT];
};

/* The record's bytes in `block` (256, the rest 0xFF) and their number; false with the reason
 * when the entries and kept versions do not fit one block or a name is not 1-16 ASCII chars. */
bool directory_encode(const struct directory_record *record, uint8_t *block, uint32_t *length,
                      struct text *why);
/* The record a slot's 256 bytes hold; false with the reason when it is no valid one. */
bool directory_decode(const uint8_t *block, struct directory_record *record, struct text *why);

/* Read both slots (and the scratch copy) and take the newest valid record: true when there is
 * one. A newer scratch copy is put back into a slot first. `report` hears each slot ignored. */
bool directory_load(struct directory_record *newest, void (*report)(const char *line));

/* Write `record` (its sequence must be the newest's + 1) as the new directory. */
bool directory_write(const struct directory_record *record, struct text *why);

/* The sequence the next write takes. */
uint32_t directory_next_sequence(void);

#endif
