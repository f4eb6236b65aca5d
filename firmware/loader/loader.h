/*
 * loader.h - one module arriving record by record, written to flash a block at a time.
 *
 * As in the paper (section 5.1) and the Python node's loader (firmware_sim/core/loader.py):
 * the load address is chosen first, incoming data waits in a 256-byte SRAM buffer, and a block
 * is programmed only once it is complete (or the image ends), after the pointer words of the 07
 * records inside it got `load_base - link_base` added: flash only clears bits, there is no
 * fixing a word afterwards. At the end every pointer word and the init target must lie inside
 * the image, and the flash is read back and its CRC-32 compared. Any failure erases what the
 * load programmed and gives its sectors back.
 */
#ifndef NODE_LOADER_H
#define NODE_LOADER_H

#include <stdbool.h>
#include <stdint.h>

#include "../kernel/text.h"
#include "flash_layout.h"
#include "signature_area.h"

#define LOADER_MAX_RELOCATIONS 64 /* per module; a descriptor has 9 method pointers */
_Static_assert(LOADER_MAX_RELOCATIONS <= 64, "load_session.applied holds a bit each");
#define SIZELESS_BLOCKS 256       /* a module typed without BEGIN: at most 64 KiB */

/* A verified image in flash, not yet committed. */
struct loaded_image {
    uint32_t link_base, load_base, size, init, relocations, crc32;
    struct extent extent;
};

struct load_session {
    bool open;
    uint32_t tid; /* its reservation is named by it, as the Python node names it */
    struct extent extent;
    uint32_t block_limit;
    uint8_t buffer[FLASH_BLOCK];
    uint32_t buffered, programmed_blocks;
    bool has_link_base, has_init, ended;
    uint32_t link_base, next_address, init, crc;
    uint16_t relocation_count;
    uint32_t relocations[LOADER_MAX_RELOCATIONS];
    uint64_t applied; /* bit i: relocations[i] was fixed in a programmed block */
};

/* Reserve flash for transfer `tid`: `size` bytes (or, without, SIZELESS_BLOCKS at most), at
 * flash address `address` when `at` (a sector boundary). */
bool loader_begin(struct load_session *session, uint32_t tid, bool sized, uint32_t size, bool at,
                  uint32_t address, struct text *why);

uint32_t loader_load_base(const struct load_session *session);
uint32_t loader_received(const struct load_session *session);
uint32_t loader_programmed(const struct load_session *session);
bool loader_has_relocation(const struct load_session *session, uint32_t location);

/* Drop the partly received block: the sender sends it again from its start. */
void loader_rewind(struct load_session *session);
/* Program the partly filled last block now (the sender waits for its acknowledgement). */
bool loader_flush(struct load_session *session, struct text *why);

/* Forget the pointer words and the init taken so far, for a header sent again (binary mode's
 * HEADER); refused once a block is programmed. */
bool loader_reset_pointers(struct load_session *session, struct text *why);
bool loader_feed_relocation(struct load_session *session, uint32_t location, struct text *why);
bool loader_feed_init(struct load_session *session, uint32_t target, struct text *why);
/* Whether a signature area of `end` bytes fits the node's; false with the refusal if not. */
bool loader_signature_fits(uint64_t end, struct text *why);
bool loader_feed_signature(struct load_session *session, uint32_t offset, const uint8_t *data,
                           uint32_t length, struct text *why);
bool loader_feed_data(struct load_session *session, uint32_t address, const uint8_t *data,
                      uint32_t length, struct text *why);

/* The end of the module: program the last block, check, read back. On success the session is
 * closed and `image` owns the flash; on failure the caller aborts. */
bool loader_finish(struct load_session *session, struct loaded_image *image, struct text *why);

/* Erase what the session programmed and give its flash back (a closed session: nothing). */
void loader_abort(struct load_session *session);
/* Erase a verified image that will not be committed, none of its code run, and give its
 * flash back. */
void loader_discard(const struct loaded_image *image);
/* Erase the sectors of `extent`, which held a module whose code ran (its init at least), and
 * retire them (flash_retire). */
void loader_erase_extent(const struct extent *extent);

#endif
