/*
 * phrase.c - bounded sentences (phrase.h).
 */
#include "phrase.h"

void phrase_start(struct phrase *phrase, char *buffer, size_t capacity)
{
    phrase->buffer = buffer;
    phrase->capacity = capacity;
    phrase->length = 0;
    if (capacity) {
        buffer[0] = '\0';
    }
}

void phrase_add_char(struct phrase *phrase, char c)
{
    if (phrase->length + 1 >= phrase->capacity) {
        return; /* full: the rest is cut, the NUL stays */
    }
    phrase->buffer[phrase->length++] = c;
    phrase->buffer[phrase->length] = '\0';
}

void phrase_add_bytes(struct phrase *phrase, const char *bytes, size_t length)
{
    for (size_t i = 0; i < length; i++) {
        phrase_add_char(phrase, bytes[i]);
    }
}

void phrase_add(struct phrase *phrase, const char *string)
{
    while (*string) {
        phrase_add_char(phrase, *string++);
    }
}

/* Digits by subtracting powers of ten: a 64-bit division would pull 2 KiB of libgcc into an
 * RV32 firmware for numbers that are nearly always small. */
static const uint64_t POWERS_OF_TEN[20] = {
    1ull, 10ull, 100ull, 1000ull, 10000ull, 100000ull, 1000000ull, 10000000ull, 100000000ull, 1000000000ull, 10000000000ull, 100000000000ull, 1000000000000ull, 10000000000000ull, 100000000000000ull, 1000000000000000ull, 10000000000000000ull, 100000000000000000ull, 1000000000000000000ull, 10000000000000000000ull};

void phrase_add_decimal(struct phrase *phrase, uint64_t value)
{
    int i = 19;
    while (i > 0 && value < POWERS_OF_TEN[i]) {
        i--;
    }
    for (; i >= 0; i--) {
        char digit = '0';
        while (value >= POWERS_OF_TEN[i]) {
            value -= POWERS_OF_TEN[i];
            digit++;
        }
        phrase_add_char(phrase, digit);
    }
}

void phrase_add_hex(struct phrase *phrase, uint32_t value, int digits)
{
    static const char HEX[] = "0123456789ABCDEF";
    int count = 8;
    while (count > 1 && count > digits && !(value >> (4 * (count - 1)))) {
        count--;
    }
    for (int i = count - 1; i >= 0; i--) {
        phrase_add_char(phrase, HEX[(value >> (4 * i)) & 0xFu]);
    }
}

/* The quote Python's repr picks: ' unless the text holds a ' and no ". */
static char repr_quote(const char *text, size_t length)
{
    int single = 0, double_ = 0;
    for (size_t i = 0; i < length; i++) {
        single |= text[i] == '\'';
        double_ |= text[i] == '"';
    }
    return single && !double_ ? '"' : '\'';
}

static void add_escaped(struct phrase *phrase, char c, char quote)
{
    static const char HEX[] = "0123456789abcdef";
    unsigned char byte = (unsigned char)c;
    if (c == quote || c == '\\') {
        phrase_add_char(phrase, '\\');
        phrase_add_char(phrase, c);
    } else if (c == '\t') {
        phrase_add(phrase, "\\t");
    } else if (c == '\n') {
        phrase_add(phrase, "\\n");
    } else if (c == '\r') {
        phrase_add(phrase, "\\r");
    } else if (byte < 0x20 || byte >= 0x7F) {
        phrase_add(phrase, "\\x");
        phrase_add_char(phrase, HEX[byte >> 4]);
        phrase_add_char(phrase, HEX[byte & 0xFu]);
    } else {
        phrase_add_char(phrase, c);
    }
}

void phrase_add_repr(struct phrase *phrase, const char *text, size_t length)
{
    char quote = repr_quote(text, length);
    phrase_add_char(phrase, quote);
    for (size_t i = 0; i < length; i++) {
        add_escaped(phrase, text[i], quote);
    }
    phrase_add_char(phrase, quote);
}

size_t name_length(const char *name, size_t most)
{
    size_t length = 0;
    while (length < most && name[length]) {
        length++;
    }
    return length;
}

int name_equal(const char *a, const char *b)
{
    while (*a && *a == *b) {
        a++;
        b++;
    }
    return *a == *b;
}

void name_copy(char *destination, const char *source, size_t capacity)
{
    size_t i = 0;
    for (; capacity && i + 1 < capacity && source[i]; i++) {
        destination[i] = source[i];
    }
    if (capacity) {
        destination[i] = '\0';
    }
}
