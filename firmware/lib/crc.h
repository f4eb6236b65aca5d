/*
 * crc.h - the two checksums the protocol and the flash use.
 *
 * CRC-32 (zlib's, reflected 0xEDB88320) checks module images and directory records, so a C
 * node and the Python node compute the same words; CRC-8 (polynomial 0x07, initial 0, as
 * SMBus's) ends every hex-mode command and answer (` *XX`).
 */
#ifndef NODE_CRC_H
#define NODE_CRC_H

#include <stddef.h>
#include <stdint.h>

/* zlib.crc32(data, crc): start with 0, feed pieces in order. */
uint32_t crc32_update(uint32_t crc, const void *data, size_t length);
uint8_t crc8_line(const char *line, size_t length);

#endif
