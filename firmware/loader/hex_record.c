/*
 * hex_record.c - the record decoder (hex_record.h). Its refusals follow the order in which
 * hexmigrate's `_diagnose` and `_check_record` look: start code, digits, length, byte count,
 * checksum, then type, size and address field.
 */
#include "hex_record.h"

#define MAX_RECORD_BYTES (255 + 5)

static int hex_digit(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    return -1;
}

/* `02 (extended segment address)`: how hexmigrate names a record type in its errors. */
static const char *type_label(uint8_t type)
{
    switch (type) {
    case RECORD_EOF: return "01 (eof)";
    case RECORD_SEGMENT: return "02 (extended segment address)";
    case RECORD_START_SEGMENT: return "03 (start segment address)";
    case RECORD_LINEAR: return "04 (extended linear address)";
    case RECORD_START_LINEAR: return "05 (start linear address)";
    case RECORD_POINTER: return "07 (offset function pointer)";
    case RECORD_INIT: return "08 (module init pointer)";
    case RECORD_SIGNATURE: return "09 (signature)";
    default: return "00 (data)";
    }
}

static int fixed_size(uint8_t type)
{
    switch (type) {
    case RECORD_EOF: return 0;
    case RECORD_SEGMENT: case RECORD_LINEAR: return 2;
    default: return 4;
    }
}

static bool known_type(uint8_t type)
{
    return type <= RECORD_START_LINEAR || (type >= RECORD_POINTER && type <= RECORD_SIGNATURE);
}

/* The digits after ':' as bytes; false with the reason when they are not a whole number of
 * hexadecimal pairs of a plausible record. */
static bool record_bytes(const char *line, size_t length, uint8_t *raw, size_t *count,
                         struct text *why)
{
    for (size_t i = 1; i < length; i++) {
        if (hex_digit(line[i]) < 0) {
            text_format(why, "expected a hexadecimal digit at column %U, got %r",
                        (uint64_t)(i + 1), &line[i], (uint32_t)1);
            return false;
        }
    }
    size_t digits = length - 1;
    if (digits % 2) {
        text_format(why, "expected an even number of hex digits, got %U", (uint64_t)digits);
        return false;
    }
    *count = digits / 2;
    if (*count < 5) {
        text_format(why, "expected at least 5 bytes (byte count, address, type, checksum), got %U",
                    (uint64_t)(*count));
        return false;
    }
    if (*count > MAX_RECORD_BYTES) {
        text_format(why, "expected %U data bytes as the byte count says, got %U", (uint64_t)raw[0],
                    (uint64_t)(*count - 5));
        return false;
    }
    for (size_t i = 0; i < *count; i++) {
        raw[i] = (uint8_t)(hex_digit(line[1 + 2 * i]) << 4 | hex_digit(line[2 + 2 * i]));
    }
    return true;
}

static bool check_frame(const uint8_t *raw, size_t count, struct text *why)
{
    if ((size_t)raw[0] + 5 != count) {
        text_format(why, "expected %U data bytes as the byte count says, got %U", (uint64_t)raw[0],
                    (uint64_t)(count - 5));
        return false;
    }
    uint8_t sum = 0;
    for (size_t i = 0; i + 1 < count; i++) {
        sum = (uint8_t)(sum + raw[i]);
    }
    uint8_t expected = (uint8_t)(0u - sum);
    if (expected != raw[count - 1]) {
        text_add(why, "expected checksum ");
        text_add_hex(why, expected, 2);
        text_add(why, ", got ");
        text_add_hex(why, raw[count - 1], 2);
        return false;
    }
    return true;
}

static bool check_kind(const struct hex_record *record, struct text *why)
{
    if (!known_type(record->type)) {
        text_add(why, "expected record type 00, 01, 02, 03, 04, 05, 07, 08 or 09, got ");
        text_add_hex(why, record->type, 2);
        return false;
    }
    if (record->type == RECORD_SIGNATURE && record->length == 0) {
        text_add(why, "expected 1 to 255 bytes for record type 09 (signature), got 0");
        return false;
    }
    if (record->type == RECORD_DATA || record->type == RECORD_SIGNATURE) {
        return true;
    }
    if (record->length != fixed_size(record->type)) {
        text_format(why, "expected a byte count of %U for record type %s, got %U",
                    (uint64_t)fixed_size(record->type), type_label(record->type),
                    (uint64_t)record->length);
        return false;
    }
    if (record->address) {
        text_format(why, "expected address field 0000 for record type %s, got ",
                    type_label(record->type));
        text_add_hex(why, record->address, 4);
        return false;
    }
    return true;
}

bool hex_record_decode(const char *line, size_t length, struct hex_record *record,
                       struct text *why)
{
    uint8_t raw[MAX_RECORD_BYTES];
    size_t count = 0;
    if (length == 0) {
        text_add(why, "expected ':' at the start of a record, got an empty line");
        return false;
    }
    if (line[0] != ':') {
        text_format(why, "expected ':' at the start of a record, got %r", line, (uint32_t)1);
        return false;
    }
    raw[0] = 0;
    if (length >= 3) {
        int high = hex_digit(line[1]), low = hex_digit(line[2]);
        raw[0] = (uint8_t)(high < 0 || low < 0 ? 0 : high << 4 | low);
    }
    if (!record_bytes(line, length, raw, &count, why) || !check_frame(raw, count, why)) {
        return false;
    }
    record->length = raw[0];
    record->address = (uint16_t)(raw[1] << 8 | raw[2]);
    record->type = raw[3];
    for (size_t i = 0; i < record->length; i++) {
        record->data[i] = raw[4 + i];
    }
    return check_kind(record, why);
}

uint32_t hex_record_value(const struct hex_record *record)
{
    uint32_t value = 0;
    for (size_t i = 0; i < record->length && i < 4; i++) {
        value = value << 8 | record->data[i];
    }
    return value;
}
