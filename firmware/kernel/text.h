/*
 * text.h - bounded text for every answer and refusal of the firmware, without libc.
 *
 * Every refusal the node makes carries a sentence that names the PBO, port, field or address and
 * says what was expected and what came, as the Python node's exceptions do, with the same words,
 * so that the host prints the same error for both nodes. A `struct text` writes into a fixed
 * buffer and silently cuts what does not fit, so no name or line a host sends can make an answer
 * overrun RAM. The kernel and the node's other parts write with this one writer.
 */
#ifndef KERNEL_TEXT_H
#define KERNEL_TEXT_H

#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>

struct text {
    char *buffer;
    uint32_t capacity; /* bytes of buffer, the NUL included */
    uint32_t length;
};

/* An empty text over `buffer` of `capacity` bytes (0: a text that takes nothing). */
void text_start(struct text *text, char *buffer, uint32_t capacity);
void text_add(struct text *text, const char *string);
void text_add_bytes(struct text *text, const char *bytes, uint32_t length);
void text_add_char(struct text *text, char c);
/* Back to its first `length` characters, a length it had: what came after is taken back. */
void text_cut(struct text *text, uint32_t length);
/* A name as Python's repr() shows it: 'gain', "it's" (text_add_repr of the whole name). */
void text_add_quoted(struct text *text, const char *name);
/* The text as Python's repr() shows a str: 'gain', "it's", 'a\tb'; a character beyond ASCII
 * (UTF-8) escaped by its code point, as repr escapes one it does not print. */
void text_add_repr(struct text *text, const char *string, uint32_t length);
/* The code point of the UTF-8 sequence at `string` (its `length` bytes left), and its size in
 * `used`; 0 bytes used when no well-formed sequence of two to four bytes starts there. Strict,
 * as Python's decoder: no overlong forms, no surrogates, nothing past U+10FFFF. */
uint32_t text_utf8_point(const unsigned char *string, uint32_t length, uint32_t *used);
/* The bytes as Python's repr() shows bytes: b'RFMD', b'\xc2\x80'. */
void text_add_bytes_repr(struct text *text, const uint8_t *data, uint32_t length);
void text_add_unsigned(struct text *text, uint64_t value);
void text_add_signed(struct text *text, int64_t value);
/* `digits` upper-case hexadecimal digits, zero-padded (Python's {:08X}); 0: as many as needed. */
void text_add_hex(struct text *text, uint32_t value, int digits);
/* 0x0800013C: eight upper-case digits, as the Python node prints addresses. */
void text_add_address(struct text *text, uint32_t value);

/*
 * Append a sentence built from `format`, which is plain text with these conversions (one call
 * per message keeps the firmware small: a call per fragment costs 16 bytes of RV32IM each):
 *   %s  a string            %q  a string as Python's repr shows it: 'gain'
 *   %r  a const char * and a uint32_t length: those characters as Python's repr shows them
 *   %u  a uint32_t          %d  an int32_t
 *   %U  a uint64_t          %D  an int64_t
 *   %a  a uint32_t address as 0x0800013C
 */
void text_format(struct text *text, const char *format, ...);
void text_vformat(struct text *text, const char *format, va_list arguments);

/* Helpers the firmware uses in place of <string.h>. */
uint32_t text_length(const char *string, uint32_t most);
bool text_equal(const char *a, const char *b);
/* a sorts before b, byte by byte (Python's sorted() on ASCII names). */
bool text_less(const char *a, const char *b);
/* Where `c` first occurs in `string`, or its length when it does not. */
uint32_t text_find(const char *string, char c);
void text_copy(char *destination, const char *source, uint32_t capacity);
void bytes_copy(void *destination, const void *source, uint32_t length);
void bytes_zero(void *destination, uint32_t length);

#endif /* KERNEL_TEXT_H */
