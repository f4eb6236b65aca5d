/*
 * text.h - bounded text for the kernel's messages, without libc.
 *
 * Every refusal the kernel makes carries a sentence that names the PBO, port or address and
 * says what was expected and what came, as the Python kernel's exceptions do; the protocol sends
 * it back to the host. A `struct text` writes into a fixed buffer and silently cuts what does
 * not fit, so a long name can never overrun kernel memory.
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

/* An empty text over `buffer` of `capacity` bytes (at least 1). */
void text_start(struct text *text, char *buffer, uint32_t capacity);
void text_add(struct text *text, const char *string);
void text_add_bytes(struct text *text, const char *bytes, uint32_t length);
/* Back to its first `length` characters, a length it had: what came after is taken back. */
void text_cut(struct text *text, uint32_t length);
/* A name as Python's repr quotes an identifier: 'gain'. */
void text_add_quoted(struct text *text, const char *name);
void text_add_unsigned(struct text *text, uint64_t value);
void text_add_signed(struct text *text, int64_t value);
/* 0x0800013C: eight upper-case digits, as the Python node prints addresses. */
void text_add_address(struct text *text, uint32_t value);

/*
 * Append a sentence built from `format`, which is plain text with these conversions (one call
 * per message keeps the firmware small: a call per fragment costs 16 bytes of RV32IM each):
 *   %s  a string            %q  a string quoted as Python's repr quotes a name: 'gain'
 *   %u  a uint32_t          %d  an int32_t
 *   %U  a uint64_t          %D  an int64_t
 *   %a  a uint32_t address as 0x0800013C
 */
void text_format(struct text *text, const char *format, ...);
void text_vformat(struct text *text, const char *format, va_list arguments);

/* Helpers the kernel uses in place of <string.h>. */
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
