/*
 * answer_memory.h - the answers of the control requests that change the node, kept to be given
 * again: a host that lost an answer asks again with the same request, which must not be done
 * twice (a START sent again would be refused, a CONNECT done twice).
 *
 * The answers lie back to back in one buffer of ANSWER_MEMORY_BYTES, the oldest dropped to make
 * room: an ACK takes 34 to 90 bytes with its 6-byte header ("started gain" to HOLD's), so in the
 * default 1 KiB 11 to 30 are kept, and at least 4 refusals of 200 characters (the Python node
 * keeps its last 64 requests of every kind; a request sent again comes right after its lost
 * answer).
 */
#ifndef NODE_ANSWER_MEMORY_H
#define NODE_ANSWER_MEMORY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../capacities/capacities.h" /* ANSWER_MEMORY_BYTES */
#include "../kernel/text.h"

/* The answer kept for the request `key` (a CRC of the whole request) added to `reply`; false
 * when none is kept. */
bool answer_memory_find(uint32_t key, struct text *reply);

/* Keep `answer` for `key`; one longer than a quarter of the memory is not kept. */
void answer_memory_keep(uint32_t key, const char *answer, size_t length);

#endif
