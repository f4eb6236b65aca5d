/*
 * number_word.c - Python's int(text, 0) grammar (number_word.h).
 */
#include "number_word.h"

/* A number past 64 bits is shown in decimal from limbs of four digits (half the RAM of one
 * byte a digit): 326 of them hold the 1,234 digits of a 1,024-character line of hex digits.
 * They lie on the stack, where the deepest path through them still fits (firmware_stack.py):
 * static, they would take their 652 bytes of RAM for good. */
#define LIMB 10000u
#define MAX_LIMBS 326

static int digit_value(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'a' && c <= 'z') {
        return c - 'a' + 10;
    }
    if (c >= 'A' && c <= 'Z') {
        return c - 'A' + 10;
    }
    return 99;
}

/* The base a prefix names (0x, 0o, 0b) and how many characters it takes; 10 and 0 without. */
static unsigned prefix_base(const char *text, size_t length, size_t *skip)
{
    *skip = 0;
    if (length >= 2 && text[0] == '0') {
        char p = text[1];
        *skip = 2;
        if (p == 'x' || p == 'X') {
            return 16;
        }
        if (p == 'o' || p == 'O') {
            return 8;
        }
        if (p == 'b' || p == 'B') {
            return 2;
        }
        *skip = 0;
    }
    return 10;
}

/* Digits of `base` with single underscores between them (and, after a prefix, before the
 * first); true when well formed. */
static bool digits_ok(const char *text, size_t length, unsigned base, bool prefixed)
{
    if (length == 0) {
        return false;
    }
    bool previous_digit = prefixed; /* "0x_1f" is a number, "_1" is not */
    for (size_t i = 0; i < length; i++) {
        if (text[i] == '_') {
            if (!previous_digit) {
                return false;
            }
            previous_digit = false;
            continue;
        }
        if ((unsigned)digit_value(text[i]) >= base) {
            return false;
        }
        previous_digit = true;
    }
    return text[length - 1] != '_';
}

/* A decimal with a leading zero is a number only when it is all zeros ("00", "0_0"). */
static bool leading_zero_ok(const char *text, size_t length)
{
    if (text[0] != '0') {
        return true;
    }
    for (size_t i = 0; i < length; i++) {
        if (text[i] != '0' && text[i] != '_') {
            return false;
        }
    }
    return true;
}

bool number_word_parse(const char *text, size_t length, struct number_word *number)
{
    number->negative = false;
    number->overflow = false;
    number->value = 0;
    if (length && (text[0] == '+' || text[0] == '-')) {
        number->negative = text[0] == '-';
        text++;
        length--;
    }
    size_t skip;
    unsigned base = prefix_base(text, length, &skip);
    if (!digits_ok(text + skip, length - skip, base, skip != 0)) {
        return false;
    }
    if (base == 10 && !leading_zero_ok(text, length)) {
        return false;
    }
    for (size_t i = skip; i < length; i++) {
        if (text[i] == '_') {
            continue;
        }
        uint64_t digit = (uint64_t)digit_value(text[i]);
        if (__builtin_mul_overflow(number->value, (uint64_t)base, &number->value) ||
            __builtin_add_overflow(number->value, digit, &number->value)) {
            number->overflow = true;
        }
    }
    if (number->value == 0 && !number->overflow) {
        number->negative = false; /* -0 is 0 */
    }
    return true;
}

/* Multiply the little-endian limbs (base LIMB) by `base` and add `digit`. */
static size_t decimal_step(uint16_t *limbs, size_t count, unsigned base, unsigned digit)
{
    uint32_t carry = digit;
    for (size_t i = 0; i < count; i++) {
        uint32_t value = limbs[i] * base + carry;
        limbs[i] = (uint16_t)(value % LIMB);
        carry = value / LIMB;
    }
    while (carry && count < MAX_LIMBS) {
        limbs[count++] = (uint16_t)(carry % LIMB);
        carry /= LIMB;
    }
    return count;
}

/* A limb below the first: its four digits, zeros included. */
static void add_limb(struct text *out, unsigned limb)
{
    for (unsigned power = LIMB / 10; power; power /= 10) {
        text_add_char(out, (char)('0' + limb / power % 10));
    }
}

void number_word_show(const char *text, size_t length, const struct number_word *number,
                      struct text *out)
{
    if (number->negative) {
        text_add_char(out, '-');
    }
    if (!number->overflow) {
        text_add_unsigned(out, number->value);
        return;
    }
    uint16_t limbs[MAX_LIMBS];
    size_t count = 1;
    limbs[0] = 0;
    if (length && (text[0] == '+' || text[0] == '-')) {
        text++;
        length--;
    }
    size_t skip;
    unsigned base = prefix_base(text, length, &skip);
    for (size_t i = skip; i < length; i++) {
        if (text[i] != '_') {
            count = decimal_step(limbs, count, base, (unsigned)digit_value(text[i]));
        }
    }
    text_add_unsigned(out, limbs[--count]);
    while (count) {
        add_limb(out, limbs[--count]);
    }
}
