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

/* The code point of the UTF-8 sequence at `text` (its `length` bytes left), and its size in
 * `used`; 0 bytes used when no well-formed sequence of two to four bytes starts there. */
static uint32_t utf8_point(const unsigned char *text, size_t length, size_t *used)
{
    static const uint32_t SMALLEST[5] = {0, 0, 0x80, 0x800, 0x10000};
    size_t size = text[0] >= 0xF0 ? 4 : text[0] >= 0xE0 ? 3 : text[0] >= 0xC0 ? 2 : 0;
    *used = 0;
    if (size == 0 || size > length || text[0] >= 0xF8) {
        return 0;
    }
    uint32_t point = text[0] & (0x7Fu >> size);
    for (size_t i = 1; i < size; i++) {
        if ((text[i] & 0xC0u) != 0x80u) {
            return 0;
        }
        point = (point << 6) | (text[i] & 0x3Fu);
    }
    if (point < SMALLEST[size] || point > 0x10FFFF || (point >= 0xD800 && point <= 0xDFFF)) {
        return 0;
    }
    *used = size;
    return point;
}

/* A character beyond ASCII as Python's repr escapes one it does not print: \xNN below 0x100,
 * \uNNNN below 0x10000, \UNNNNNNNN above. (Python prints the printable ones as they are; the
 * node cannot tell which those are, so its refusal differs from the Python node's there.) */
static void add_escaped_point(struct phrase *phrase, uint32_t point)
{
    static const char HEX[] = "0123456789abcdef";
    int digits = point < 0x100 ? 2 : point < 0x10000 ? 4 : 8;
    phrase_add(phrase, point < 0x100 ? "\\x" : point < 0x10000 ? "\\u" : "\\U");
    for (int i = digits - 1; i >= 0; i--) {
        phrase_add_char(phrase, HEX[(point >> (4 * i)) & 0xFu]);
    }
}

void phrase_add_bytes_repr(struct phrase *phrase, const uint8_t *data, size_t length)
{
    char quote = repr_quote((const char *)data, length);
    phrase_add_char(phrase, 'b');
    phrase_add_char(phrase, quote);
    for (size_t i = 0; i < length; i++) {
        add_escaped(phrase, (char)data[i], quote);
    }
    phrase_add_char(phrase, quote);
}

void phrase_add_repr(struct phrase *phrase, const char *text, size_t length)
{
    char quote = repr_quote(text, length);
    phrase_add_char(phrase, quote);
    for (size_t i = 0; i < length; i++) {
        size_t used = 0;
        uint32_t point = 0;
        if ((unsigned char)text[i] >= 0x80) {
            point = utf8_point((const unsigned char *)text + i, length - i, &used);
        }
        if (used) {
            add_escaped_point(phrase, point);
            i += used - 1;
        } else {
            add_escaped(phrase, text[i], quote);
        }
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
