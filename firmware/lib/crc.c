/*
 * crc.c - CRC-32 and CRC-8 bit by bit: no tables, so no RAM or flash spent on them; an image
 * of 64 KiB costs a few milliseconds, far below what the UART takes to bring it.
 */
#include "crc.h"

uint32_t crc32_update(uint32_t crc, const void *data, size_t length)
{
    const uint8_t *bytes = data;
    crc = ~crc;
    for (size_t i = 0; i < length; i++) {
        crc ^= bytes[i];
        for (int bit = 0; bit < 8; bit++) {
            crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
        }
    }
    return ~crc;
}

uint8_t crc8_line(const char *line, size_t length)
{
    uint8_t crc = 0;
    for (size_t i = 0; i < length; i++) {
        crc ^= (uint8_t)line[i];
        for (int bit = 0; bit < 8; bit++) {
            crc = (uint8_t)((crc & 0x80u) ? (unsigned)(crc << 1) ^ 0x07u : (unsigned)(crc << 1));
        }
    }
    return crc;
}
