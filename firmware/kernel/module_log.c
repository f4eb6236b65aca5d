/*
 * module_log.c - the kept module log lines (see module_log.h).
 *
 * Records sit back to back from the buffer's start, oldest first: a fixed header, then the
 * text. A line that does not fit drops the oldest records and moves the rest to the front, a
 * copy of at most MODULE_LOG_BYTES made only when the buffer is full: simpler to get right than
 * a ring whose records wrap, at a cost a LOG call can afford.
 */
#include "module_log.h"

#include "abi.h"
#include "config.h"
#include "text.h"

struct header {
    uint64_t time_us;
    uint32_t owner;
    uint32_t number;
    uint32_t length; /* of the text after the header */
    uint32_t size;   /* of the whole record, a multiple of 8 */
};

static struct {
    uint32_t end; /* bytes in use */
    _Alignas(8) uint8_t bytes[MODULE_LOG_BYTES];
} kept;

_Static_assert(sizeof(struct header) + ABI_LOG_LIMIT <= MODULE_LOG_BYTES,
               "the longest line must fit the log");

void module_log_reset(void)
{
    kept.end = 0;
}

static struct header *record_at(uint32_t offset)
{
    return (struct header *)(void *)&kept.bytes[offset];
}

/* Drop the oldest records until `size` more bytes fit. */
static void make_room(uint32_t size)
{
    uint32_t dropped = 0;

    while (kept.end - dropped + size > MODULE_LOG_BYTES) {
        dropped += record_at(dropped)->size;
    }
    if (dropped != 0) {
        bytes_copy(kept.bytes, &kept.bytes[dropped], kept.end - dropped);
        kept.end -= dropped;
    }
}

void module_log_append(uint32_t owner, uint32_t number, uint64_t time_us, const char *text,
                       uint32_t length)
{
    struct header *header;
    const uint32_t cut = length < ABI_LOG_LIMIT ? length : ABI_LOG_LIMIT;
    const uint32_t size = ((uint32_t)sizeof(struct header) + cut + 7u) & ~7u;

    make_room(size);
    header = record_at(kept.end);
    header->time_us = time_us;
    header->owner = owner;
    header->number = number;
    header->length = cut;
    header->size = size;
    bytes_copy(header + 1, text, cut);
    kept.end += size;
}

void module_log_since(uint32_t owner, uint32_t since, log_visitor visit, void *context)
{
    for (uint32_t offset = 0; offset < kept.end; offset += record_at(offset)->size) {
        const struct header *header = record_at(offset);
        if (header->owner == owner && header->number > since) {
            const struct log_line line = {header->number, header->time_us, header->length,
                                          (const char *)(header + 1)};
            visit(&line, context);
        }
    }
}
