/*
 * hex_record.h - one extended Intel HEX record line, decoded and checked.
 *
 * The node takes a module line by line as it arrives (docs/hex-format.md): 00 data, 01 end of
 * file, 02/03 segment, 04/05 linear, 07 offset function pointer, 08 init pointer, 09 signature
 * area. A line that is no valid record is refused with the words hexmigrate's decoder uses
 * (`hexmigrate.records.decode_record`), so the host's error reads the same for both nodes.
 */
#ifndef NODE_HEX_RECORD_H
#define NODE_HEX_RECORD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../kernel/text.h"

enum record_type {
    RECORD_DATA = 0x00,
    RECORD_EOF = 0x01,
    RECORD_SEGMENT = 0x02,
    RECORD_START_SEGMENT = 0x03,
    RECORD_LINEAR = 0x04,
    RECORD_START_LINEAR = 0x05,
    RECORD_POINTER = 0x07,
    RECORD_INIT = 0x08,
    RECORD_SIGNATURE = 0x09,
};

struct hex_record {
    uint8_t type;
    uint16_t address; /* the address field */
    uint8_t length;   /* data bytes */
    uint8_t data[255];
};

/* Decode `line` (the whole stripped line, its ':' included); false with the reason in `why`. */
bool hex_record_decode(const char *line, size_t length, struct hex_record *record,
                       struct text *why);

/* The data as a big-endian number: the address records' and pointers' value. */
uint32_t hex_record_value(const struct hex_record *record);

#endif
