/*
 * phrase.h - a bounded sentence in a fixed buffer: what every answer and refusal is built in.
 *
 * The node's refusals say what was expected and what came, as the Python node's do, with the
 * same words, so that the host prints the same error for both nodes. A `struct phrase` writes
 * into a caller's buffer and cuts what does not fit (it never writes past it), so no name or
 * line a host sends can make an answer overrun RAM.
 */
#ifndef NODE_PHRASE_H
#define NODE_PHRASE_H

#include <stddef.h>
#include <stdint.h>

struct phrase {
    char *buffer;
    size_t capacity; /* bytes of buffer, the NUL included */
    size_t length;
};

void phrase_start(struct phrase *phrase, char *buffer, size_t capacity);
void phrase_add(struct phrase *phrase, const char *string);
void phrase_add_bytes(struct phrase *phrase, const char *bytes, size_t length);
void phrase_add_char(struct phrase *phrase, char c);
void phrase_add_decimal(struct phrase *phrase, uint64_t value);
/* `digits` upper-case hexadecimal digits, zero-padded (Python's {:08X}); 0: as many as needed. */
void phrase_add_hex(struct phrase *phrase, uint32_t value, int digits);
/* The text as Python's repr() shows a str: 'gain', "it's", 'a\tb'; a character beyond ASCII
 * (UTF-8) escaped by its code point, as repr escapes one it does not print. */
void phrase_add_repr(struct phrase *phrase, const char *text, size_t length);
/* The bytes as Python's repr() shows bytes: b'RFMD', b'\xc2\x80'. */
void phrase_add_bytes_repr(struct phrase *phrase, const uint8_t *data, size_t length);

/* Helpers for NUL-terminated names, in place of <string.h>. */
size_t name_length(const char *name, size_t most);
int name_equal(const char *a, const char *b);
void name_copy(char *destination, const char *source, size_t capacity);

#endif
