/*
 * pbo_printf.h - a small printf for a module's log (docs/module-abi.md, "The C a module may use").
 *
 *     pbo_printf("x=%d gain=%q y=%08x %s", x, k, y, "ok");
 *
 * formats into a buffer on the stack and sends it with one LOG service call, so the text reaches
 * the node's log as the module's. There is no libc stdio in a module (it would need static state
 * and a console), and a full vsnprintf is some kilobytes of flash to migrate; this is what a
 * control module logs: integers, text and the SDK's Q16.16 fixed point.
 *
 * Conversions: %d %i (int32_t), %u (uint32_t), %x %X (uint32_t, hexadecimal), %c, %s, %% and
 * %q (a Q16.16 int32_t as a decimal: %q gives 4 fraction digits, %.Nq gives N, 0 to 9, rounded
 * to nearest). Flags '-' (left-justify) and '0' (pad numbers with zeros), a width of up to 99.
 * Anything else is copied as it is, so a wrong format shows in the log instead of faulting.
 * The text is cut at PBO_PRINTF_LIMIT bytes, the most one LOG call takes.
 */
#ifndef PBO_PRINTF_H
#define PBO_PRINTF_H

#include <stdarg.h>

#include "pbo_module.h"

#define PBO_PRINTF_LIMIT 256u /* the node's LOG_LIMIT */
#define PBO_PRINTF_DEFAULT_Q_DIGITS 4u
#define PBO_PRINTF_MAX_Q_DIGITS 9u

struct pbo_printf_out {
    char text[PBO_PRINTF_LIMIT];
    uint32_t length;
};

struct pbo_printf_spec {
    uint32_t width;
    uint32_t precision;
    uint8_t left;
    uint8_t zeros;
    uint8_t has_precision;
};

static inline void pbo_printf_put(struct pbo_printf_out *out, char c)
{
    if (out->length < PBO_PRINTF_LIMIT) {
        out->text[out->length++] = c;
    }
}

/* `digits` (most significant first) after `sign` (0 for none), padded to the spec's width. */
static inline void pbo_printf_field(struct pbo_printf_out *out, const struct pbo_printf_spec *spec,
                                    char sign, const char *digits, uint32_t count)
{
    const uint32_t used = count + (sign != 0);
    const uint32_t pad = spec->width > used ? spec->width - used : 0u;
    uint32_t i;

    if (!spec->left && !spec->zeros) {
        for (i = 0; i < pad; i++) {
            pbo_printf_put(out, ' ');
        }
    }
    if (sign != 0) {
        pbo_printf_put(out, sign);
    }
    if (!spec->left && spec->zeros) {
        for (i = 0; i < pad; i++) {
            pbo_printf_put(out, '0');
        }
    }
    for (i = 0; i < count; i++) {
        pbo_printf_put(out, digits[i]);
    }
    if (spec->left) {
        for (i = 0; i < pad; i++) {
            pbo_printf_put(out, ' ');
        }
    }
}

/* The digits of `value` in `base` into `buffer` (at least 32 bytes), most significant first. */
static inline uint32_t pbo_printf_digits(char *buffer, uint32_t value, uint32_t base, int upper)
{
    const char *symbols = upper ? "0123456789ABCDEF" : "0123456789abcdef";
    char reversed[32];
    uint32_t count = 0;
    uint32_t i;

    do {
        reversed[count++] = symbols[value % base];
        value /= base;
    } while (value != 0);
    for (i = 0; i < count; i++) {
        buffer[i] = reversed[count - 1u - i];
    }
    return count;
}

/* A Q16.16 value as [-]integer.fraction with `places` fraction digits, rounded to nearest. */
static inline void pbo_printf_q16(struct pbo_printf_out *out, const struct pbo_printf_spec *spec,
                                  int32_t q)
{
    const uint32_t places = spec->has_precision ? spec->precision : PBO_PRINTF_DEFAULT_Q_DIGITS;
    const uint32_t magnitude = q < 0 ? 0u - (uint32_t)q : (uint32_t)q;
    uint64_t scale = 1;
    uint32_t whole = magnitude >> 16;
    uint64_t fraction;
    char buffer[48];
    uint32_t count;
    uint32_t i;

    for (i = 0; i < places; i++) {
        scale *= 10u;
    }
    fraction = ((uint64_t)(magnitude & 0xFFFFu) * scale + 0x8000u) >> 16;
    if (fraction >= scale) { /* rounded up into the next integer */
        fraction -= scale;
        whole += 1u;
    }
    count = pbo_printf_digits(buffer, whole, 10u, 0);
    if (places != 0) {
        buffer[count++] = '.';
        for (i = places; i > 0; i--) {
            buffer[count + i - 1u] = (char)('0' + (uint32_t)(fraction % 10u));
            fraction /= 10u;
        }
        count += places;
    }
    pbo_printf_field(out, spec, q < 0 ? '-' : 0, buffer, count);
}

/* One conversion after its '%' and spec; returns 0 for a conversion it does not know. */
static inline int pbo_printf_convert(struct pbo_printf_out *out, const struct pbo_printf_spec *spec,
                                     char conversion, va_list *arguments)
{
    char buffer[32];
    uint32_t count;

    switch (conversion) {
    case 'd':
    case 'i': {
        const int32_t value = va_arg(*arguments, int32_t);
        const uint32_t magnitude = value < 0 ? 0u - (uint32_t)value : (uint32_t)value;
        count = pbo_printf_digits(buffer, magnitude, 10u, 0);
        pbo_printf_field(out, spec, value < 0 ? '-' : 0, buffer, count);
        return 1;
    }
    case 'u':
        count = pbo_printf_digits(buffer, va_arg(*arguments, uint32_t), 10u, 0);
        pbo_printf_field(out, spec, 0, buffer, count);
        return 1;
    case 'x':
    case 'X':
        count = pbo_printf_digits(buffer, va_arg(*arguments, uint32_t), 16u, conversion == 'X');
        pbo_printf_field(out, spec, 0, buffer, count);
        return 1;
    case 'q':
        pbo_printf_q16(out, spec, va_arg(*arguments, int32_t));
        return 1;
    case 'c':
        buffer[0] = (char)va_arg(*arguments, int);
        pbo_printf_field(out, spec, 0, buffer, 1u);
        return 1;
    case 's': {
        const char *text = va_arg(*arguments, const char *);
        uint32_t length = 0;
        while (text[length] != '\0' && length < PBO_PRINTF_LIMIT) {
            length++;
        }
        pbo_printf_field(out, spec, 0, text, length);
        return 1;
    }
    case '%':
        pbo_printf_put(out, '%');
        return 1;
    default:
        return 0;
    }
}

/* Reads flags, width and precision after a '%'; returns where the conversion letter is. */
static inline const char *pbo_printf_read_spec(const char *at, struct pbo_printf_spec *spec)
{
    *spec = (struct pbo_printf_spec){0};
    for (; *at == '-' || *at == '0'; at++) {
        spec->left |= *at == '-';
        spec->zeros |= *at == '0';
    }
    while (*at >= '0' && *at <= '9' && spec->width < 10u) {
        spec->width = spec->width * 10u + (uint32_t)(*at++ - '0');
    }
    if (*at == '.') {
        spec->has_precision = 1;
        for (at++; *at >= '0' && *at <= '9'; at++) {
            spec->precision = spec->precision * 10u + (uint32_t)(*at - '0');
            if (spec->precision > PBO_PRINTF_MAX_Q_DIGITS) {
                spec->precision = PBO_PRINTF_MAX_Q_DIGITS;
            }
        }
    }
    return at;
}

/* Formats and logs; returns the LOG service's status (PBO_OK) like pbo_sys_log. (No format
 * attribute: the compiler's printf checks would refuse %q.) */
static inline int32_t pbo_printf(const char *format, ...)
{
    struct pbo_printf_out out;
    struct pbo_printf_spec spec;
    va_list arguments;
    const char *at = format;

    out.length = 0;
    va_start(arguments, format);
    while (*at != '\0') {
        if (*at != '%') {
            pbo_printf_put(&out, *at++);
            continue;
        }
        const char *start = at;
        at = pbo_printf_read_spec(at + 1, &spec);
        if (*at != '\0' && pbo_printf_convert(&out, &spec, *at, &arguments)) {
            at++;
            continue;
        }
        while (start < at) { /* not a conversion: the text as it is */
            pbo_printf_put(&out, *start++);
        }
    }
    va_end(arguments);
    return pbo_sys_log(out.text, out.length);
}

#endif /* PBO_PRINTF_H */
