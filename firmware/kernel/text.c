/* text.c - bounded text and the few byte helpers the kernel needs (see text.h). */
#include "text.h"

void text_start(struct text *text, char *buffer, uint32_t capacity)
{
    text->buffer = buffer;
    text->capacity = capacity;
    text->length = 0;
    buffer[0] = '\0';
}

void text_add_bytes(struct text *text, const char *bytes, uint32_t length)
{
    for (uint32_t i = 0; i < length && text->length + 1 < text->capacity; i++) {
        text->buffer[text->length++] = bytes[i];
    }
    text->buffer[text->length] = '\0';
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
    text_add(text, "'");
    text_add(text, name);
    text_add(text, "'");
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

void text_add_address(struct text *text, uint32_t value)
{
    static const char hex[] = "0123456789ABCDEF";
    char digits[10] = {'0', 'x'};

    for (uint32_t i = 0; i < 8; i++) {
        digits[2 + i] = hex[(value >> (28u - 4u * i)) & 0xFu];
    }
    text_add_bytes(text, digits, sizeof digits);
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
