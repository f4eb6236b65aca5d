/* setting.c - a SET request's PBO.port=VALUE (setting.h). */
#include "setting.h"

#include "../protocol/number_word.h"
#include "ports.h"

/* A decimal float as Python's float() reads it: [sign] digits [. digits] [e [sign] digits],
 * one digit at least before the exponent; whether it is whole, and its value when it is. */
struct decimal {
    bool negative, whole, too_large;
    int64_t value;
};

static bool is_digit(char c)
{
    return c >= '0' && c <= '9';
}

static size_t digits_at(const char *text, size_t length, size_t at)
{
    size_t end = at;
    while (end < length && is_digit(text[end])) {
        end++;
    }
    return end - at;
}

/* The exponent after `e`, or false when there is none that Python would take. */
static bool exponent_at(const char *text, size_t length, size_t at, int32_t *exponent)
{
    bool negative = at < length && text[at] == '-';
    at += at < length && (text[at] == '-' || text[at] == '+') ? 1u : 0u;
    size_t count = digits_at(text, length, at);
    if (count == 0 || at + count != length) {
        return false;
    }
    int32_t value = 0;
    for (size_t i = at; i < length; i++) {
        value = value < 100000 ? value * 10 + (text[i] - '0') : value;
    }
    *exponent = negative ? -value : value;
    return true;
}

/* The digits of the mantissa scaled by 10^exponent, as an integer when no fraction is left. */
static void scale(const char *digits, size_t count, int32_t exponent, struct decimal *decimal)
{
    uint64_t value = 0;
    decimal->whole = true;
    for (size_t i = 0; i < count; i++) {
        int32_t place = (int32_t)(count - i) - 1 + exponent; /* this digit's power of ten */
        int digit = digits[i] - '0';
        if (place < 0 && digit != 0) {
            decimal->whole = false;
        }
        if (place >= 0 && (value > (UINT64_MAX - 9u) / 10u)) {
            decimal->too_large = true;
        }
        value = place >= 0 && !decimal->too_large ? value * 10u + (uint64_t)digit : value;
    }
    for (int32_t extra = exponent; extra > 0 && !decimal->too_large; extra--) {
        decimal->too_large = value > UINT64_MAX / 10u;
        value *= 10u;
    }
    decimal->too_large = decimal->too_large || value > (uint64_t)INT64_MAX;
    decimal->value = (int64_t)value;
}

static bool parse_decimal(const char *text, size_t length, struct decimal *decimal)
{
    char digits[64];
    size_t count = 0, at = 0;
    int32_t exponent = 0;

    if (length == 0) {
        return false;
    }
    *decimal = (struct decimal){text[0] == '-', true, false, 0};
    at += length && (text[0] == '-' || text[0] == '+') ? 1u : 0u;
    size_t before = digits_at(text, length, at);
    for (size_t i = 0; i < before && count < sizeof digits; i++) {
        digits[count++] = text[at + i];
    }
    at += before;
    size_t after = 0;
    if (at < length && text[at] == '.') {
        after = digits_at(text, length, at + 1);
        for (size_t i = 0; i < after && count < sizeof digits; i++) {
            digits[count++] = text[at + 1 + i];
        }
        at += 1 + after;
    }
    if (before + after == 0 || before + after > sizeof digits) {
        return false;
    }
    if (at < length && !((text[at] == 'e' || text[at] == 'E') &&
                         exponent_at(text, length, at + 1, &exponent))) {
        return false;
    }
    scale(digits, count, exponent - (int32_t)after, decimal);
    if (decimal->negative) {
        decimal->value = -decimal->value;
    }
    return true;
}

/* inf, infinity, nan with a sign or not, any case: a float Python reads and refuses later. */
static bool not_finite(const char *text, size_t length)
{
    static const char *const WORDS[] = {"inf", "infinity", "nan"};
    size_t at = length && (text[0] == '-' || text[0] == '+') ? 1u : 0u;
    for (size_t w = 0; w < 3; w++) {
        size_t n = text_length(WORDS[w], 9), i = 0;
        while (i < n && at + i < length && (text[at + i] | 0x20) == WORDS[w][i]) {
            i++;
        }
        if (i == n && at + n == length) {
            return true;
        }
    }
    return false;
}

static bool parse_value(const char *text, size_t length, struct setting *setting,
                        struct text *why)
{
    struct number_word number;
    struct decimal decimal;

    if (number_word_parse(text, length, &number)) {
        setting->whole = true;
        setting->too_large = number.overflow || number.value > (uint64_t)INT64_MAX;
        setting->value = number.negative ? -(int64_t)number.value : (int64_t)number.value;
        return true;
    }
    if (not_finite(text, length)) {
        text_format(why, "expected a finite number, got %r", text, (uint32_t)length);
        return false;
    }
    if (!parse_decimal(text, length, &decimal)) {
        text_format(why, "expected a number like 3, 0x20000 or 1.5, got %r", text,
                    (uint32_t)length);
        return false;
    }
    setting->whole = decimal.whole;
    setting->too_large = decimal.too_large;
    setting->value = decimal.value;
    return true;
}

bool setting_parse(const char *text, size_t length, struct setting *setting, struct text *why)
{
    size_t equals = 0, dot = 0, dots = 0;
    while (equals < length && text[equals] != '=') {
        equals++;
    }
    for (size_t i = 0; i < equals; i++) {
        dots += text[i] == '.' ? 1u : 0u;
        dot = dots == 1 && text[i] == '.' ? i : dot;
    }
    /* PBO.port=VALUE: one dot, a PBO and a port on either side of it */
    if (equals == length || dots != 1 || dot == 0 || dot + 1 == equals) {
        text_format(why, "expected PBO.port=VALUE, got %r", text, (uint32_t)length);
        return false;
    }
    setting->port = ports_name(0, text, equals);
    setting->text = text + equals + 1;
    setting->text_length = length - equals - 1;
    return parse_value(setting->text, setting->text_length, setting, why);
}

void setting_show(const struct setting *setting, struct text *text)
{
    const char *value = setting->text;
    size_t length = setting->text_length, point = 0;
    while (point < length && value[point] != '.') {
        point++;
    }
    for (size_t i = 0; i < length; i++) {
        if (value[i] == 'e' || value[i] == 'E' || value[i] == '_') {
            text_add_bytes(text, value, length); /* shown as given: Python would normalize */
            return;
        }
    }
    if (point < length) {
        while (length > point + 2 && value[length - 1] == '0') {
            length--; /* 1.50 -> 1.5, as repr */
        }
    }
    text_add_bytes(text, value, length);
}
