/* text.c - bounded text and the few byte helpers the firmware needs (see text.h). */
#include "text.h"

void text_start(struct text *text, char *buffer, uint32_t capacity)
{
    text->buffer = buffer;
    text->capacity = capacity;
    text->length = 0;
    if (capacity != 0) {
        buffer[0] = '\0';
    }
}

void text_add_bytes(struct text *text, const char *bytes, uint32_t length)
{
    if (text->capacity == 0) {
        return; /* no room even for the NUL */
    }
    for (uint32_t i = 0; i < length && text->length + 1 < text->capacity; i++) {
        text->buffer[text->length++] = bytes[i];
    }
    text->buffer[text->length] = '\0';
}

void text_add_char(struct text *text, char c)
{
    text_add_bytes(text, &c, 1);
}

void text_cut(struct text *text, uint32_t length)
{
    if (length < text->length) {
        text->length = length;
        text->buffer[length] = '\0';
    }
}

void text_add(struct text *text, const char *string)
{
    text_add_bytes(text, string, text_length(string, UINT32_MAX));
}

void text_add_quoted(struct text *text, const char *name)
{
    text_add_repr(text, name, text_length(name, UINT32_MAX));
}

/* The quote Python's repr picks: ' unless the text holds a ' and no ". */
static char repr_quote(const char *string, uint32_t length)
{
    bool single = false, double_ = false;
    for (uint32_t i = 0; i < length; i++) {
        single |= string[i] == '\'';
        double_ |= string[i] == '"';
    }
    return single && !double_ ? '"' : '\'';
}

static void add_escaped(struct text *text, char c, char quote)
{
    static const char HEX[] = "0123456789abcdef";
    unsigned char byte = (unsigned char)c;
    if (c == quote || c == '\\') {
        text_add_char(text, '\\');
        text_add_char(text, c);
    } else if (c == '\t') {
        text_add(text, "\\t");
    } else if (c == '\n') {
        text_add(text, "\\n");
    } else if (c == '\r') {
        text_add(text, "\\r");
    } else if (byte < 0x20 || byte >= 0x7F) {
        text_add(text, "\\x");
        text_add_char(text, HEX[byte >> 4]);
        text_add_char(text, HEX[byte & 0xFu]);
    } else {
        text_add_char(text, c);
    }
}

uint32_t text_utf8_point(const unsigned char *string, uint32_t length, uint32_t *used)
{
    static const uint32_t SMALLEST[5] = {0, 0, 0x80, 0x800, 0x10000};
    uint32_t size = string[0] >= 0xF0 ? 4 : string[0] >= 0xE0 ? 3 : string[0] >= 0xC0 ? 2 : 0;
    *used = 0;
    if (size == 0 || size > length || string[0] >= 0xF8) {
        return 0;
    }
    uint32_t point = string[0] & (0x7Fu >> size);
    for (uint32_t i = 1; i < size; i++) {
        if ((string[i] & 0xC0u) != 0x80u) {
            return 0;
        }
        point = (point << 6) | (string[i] & 0x3Fu);
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
static void add_escaped_point(struct text *text, uint32_t point)
{
    static const char HEX[] = "0123456789abcdef";
    int digits = point < 0x100 ? 2 : point < 0x10000 ? 4 : 8;
    text_add(text, point < 0x100 ? "\\x" : point < 0x10000 ? "\\u" : "\\U");
    for (int i = digits - 1; i >= 0; i--) {
        text_add_char(text, HEX[(point >> (4 * i)) & 0xFu]);
    }
}

void text_add_bytes_repr(struct text *text, const uint8_t *data, uint32_t length)
{
    char quote = repr_quote((const char *)data, length);
    text_add_char(text, 'b');
    text_add_char(text, quote);
    for (uint32_t i = 0; i < length; i++) {
        add_escaped(text, (char)data[i], quote);
    }
    text_add_char(text, quote);
}

void text_add_repr(struct text *text, const char *string, uint32_t length)
{
    char quote = repr_quote(string, length);
    text_add_char(text, quote);
    for (uint32_t i = 0; i < length; i++) {
        uint32_t used = 0;
        uint32_t point = 0;
        if ((unsigned char)string[i] >= 0x80) {
            point = text_utf8_point((const unsigned char *)string + i, length - i, &used);
        }
        if (used) {
            add_escaped_point(text, point);
            i += used - 1;
        } else {
            add_escaped(text, string[i], quote);
        }
    }
    text_add_char(text, quote);
}

void text_add_unsigned(struct text *text, uint64_t value)
{
    char digits[20];
    uint32_t count = 0;

    do {
        digits[count++] = (char)('0' + value % 10u);
        value /= 10u;
    } while (value != 0);
    while (count > 0) {
        text_add_bytes(text, &digits[--count], 1);
    }
}

void text_add_signed(struct text *text, int64_t value)
{
    if (value < 0) {
        text_add(text, "-");
        /* the magnitude in unsigned arithmetic: -INT64_MIN does not fit an int64_t */
        text_add_unsigned(text, (uint64_t)0 - (uint64_t)value);
        return;
    }
    text_add_unsigned(text, (uint64_t)value);
}

void text_add_hex(struct text *text, uint32_t value, int digits)
{
    static const char HEX[] = "0123456789ABCDEF";
    int count = 8;
    while (count > 1 && count > digits && !(value >> (4 * (count - 1)))) {
        count--;
    }
    for (int i = count - 1; i >= 0; i--) {
        text_add_char(text, HEX[(value >> (4 * i)) & 0xFu]);
    }
}

void text_add_address(struct text *text, uint32_t value)
{
    text_add(text, "0x");
    text_add_hex(text, value, 8);
}

static void add_conversion(struct text *text, char conversion, va_list *arguments)
{
    switch (conversion) {
    case 's':
        text_add(text, va_arg(*arguments, const char *));
        break;
    case 'q':
        text_add_quoted(text, va_arg(*arguments, const char *));
        break;
    case 'r': {
        const char *string = va_arg(*arguments, const char *);
        text_add_repr(text, string, va_arg(*arguments, uint32_t));
        break;
    }
    case 'u':
        text_add_unsigned(text, va_arg(*arguments, uint32_t));
        break;
    case 'd':
        text_add_signed(text, va_arg(*arguments, int32_t));
        break;
    case 'U':
        text_add_unsigned(text, va_arg(*arguments, uint64_t));
        break;
    case 'D':
        text_add_signed(text, va_arg(*arguments, int64_t));
        break;
    case 'a':
        text_add_address(text, va_arg(*arguments, uint32_t));
        break;
    default:
        text_add_bytes(text, &conversion, 1);
    }
}

void text_format(struct text *text, const char *format, ...)
{
    va_list arguments;

    va_start(arguments, format);
    text_vformat(text, format, arguments);
    va_end(arguments);
}

void text_vformat(struct text *text, const char *format, va_list given)
{
    va_list arguments; /* a copy of our own: a va_list parameter may be an array type */

    va_copy(arguments, given);
    while (*format != '\0') {
        const uint32_t plain = text_find(format, '%');
        text_add_bytes(text, format, plain);
        format += plain;
        if (*format == '%' && format[1] != '\0') {
            add_conversion(text, format[1], &arguments);
            format += 2;
        } else if (*format == '%') {
            format++;
        }
    }
    va_end(arguments);
}

uint32_t text_length(const char *string, uint32_t most)
{
    uint32_t length = 0;
    while (length < most && string[length] != '\0') {
        length++;
    }
    return length;
}

bool text_equal(const char *a, const char *b)
{
    while (*a != '\0' && *a == *b) {
        a++;
        b++;
    }
    return *a == *b;
}

bool text_less(const char *a, const char *b)
{
    while (*a != '\0' && *a == *b) {
        a++;
        b++;
    }
    return (unsigned char)*a < (unsigned char)*b;
}

uint32_t text_find(const char *string, char c)
{
    uint32_t i = 0;
    while (string[i] != '\0' && string[i] != c) {
        i++;
    }
    return i;
}

void text_copy(char *destination, const char *source, uint32_t capacity)
{
    struct text text;
    text_start(&text, destination, capacity);
    text_add(&text, source);
}

/* The firmware may link no libc: keep gcc from turning these loops into memmove/memset calls. */
#define NO_LIBC_CALLS __attribute__((optimize("no-tree-loop-distribute-patterns")))

NO_LIBC_CALLS void bytes_copy(void *destination, const void *source, uint32_t length)
{
    unsigned char *to = destination;
    const unsigned char *from = source;

    /* memmove semantics: a guest may pass overlapping buffers (PORT_WRITE from its own port) */
    if (to < from) {
        for (uint32_t i = 0; i < length; i++) {
            to[i] = from[i];
        }
    } else {
        for (uint32_t i = length; i > 0; i--) {
            to[i - 1] = from[i - 1];
        }
    }
}

NO_LIBC_CALLS void bytes_zero(void *destination, uint32_t length)
{
    unsigned char *to = destination;
    for (uint32_t i = 0; i < length; i++) {
        to[i] = 0;
    }
}
