/*
 * answer_memory.c - answers kept back to back, the oldest first (answer_memory.h).
 */
#include "answer_memory.h"

#define HEADER 6 /* the key (4 bytes) and the answer's length (2), little-endian */

static struct {
    uint8_t bytes[ANSWER_MEMORY_BYTES];
    size_t used;
} memory;

static uint32_t read_key(size_t at)
{
    const uint8_t *b = memory.bytes + at;
    return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}

static size_t read_length(size_t at)
{
    return (size_t)memory.bytes[at + 4] | (size_t)memory.bytes[at + 5] << 8;
}

bool answer_memory_find(uint32_t key, struct text *reply)
{
    for (size_t at = 0; at < memory.used; at += HEADER + read_length(at)) {
        if (read_key(at) == key) {
            text_add_bytes(reply, (const char *)memory.bytes + at + HEADER, read_length(at));
            return true;
        }
    }
    return false;
}

/* Drop the oldest answer: the others move to the buffer's start. */
static void drop_oldest(void)
{
    size_t first = HEADER + read_length(0);
    for (size_t i = first; i < memory.used; i++) {
        memory.bytes[i - first] = memory.bytes[i];
    }
    memory.used -= first;
}

void answer_memory_keep(uint32_t key, const char *answer, size_t length)
{
    if (HEADER + length > ANSWER_MEMORY_BYTES / 4) {
        return; /* no answer of these is so long; one cut would be worse than none */
    }
    while (memory.used + HEADER + length > ANSWER_MEMORY_BYTES) {
        drop_oldest();
    }
    uint8_t *entry = memory.bytes + memory.used;
    for (int i = 0; i < 4; i++) {
        entry[i] = (uint8_t)(key >> (8 * i));
    }
    entry[4] = (uint8_t)length;
    entry[5] = (uint8_t)(length >> 8);
    for (size_t i = 0; i < length; i++) {
        entry[HEADER + i] = (uint8_t)answer[i];
    }
    memory.used += HEADER + length;
}
