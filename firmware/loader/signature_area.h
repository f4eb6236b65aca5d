/*
 * signature_area.h - what the node keeps of a signed module's signature area while it arrives.
 *
 * The firmware checks no signature yet (docs/firmware.md), so it keeps the area only to know a
 * piece sent again (the header sent again after a lost acknowledgement) from other bytes, which
 * end the transfer, as the Python node does. Not its bytes, up to 4 KiB, a quarter of the
 * firmware's RAM budget: the CRC-32 of every prefix ending on a 32-byte boundary (a 09 line's
 * size, hexmigrate.records.SIGNATURE_RECORD_SIZE; a binary SIGNATURE's piece is a multiple) and
 * of the whole. A piece sent again is known when its CRC, continued from the prefix its start
 * ends, gives the prefix its end ends. A node that checks signatures would instead hash what
 * the area covers as it comes and keep the short signature TLVs.
 */
#ifndef NODE_SIGNATURE_AREA_H
#define NODE_SIGNATURE_AREA_H

#include <stdbool.h>
#include <stdint.h>

#define SIGNATURE_AREA_MAX 4096 /* hexmigrate.records.MAX_SIGNATURE_AREA */
#define SIGNATURE_GRAIN 32      /* hexmigrate.records.SIGNATURE_RECORD_SIZE */

struct signature_area {
    uint32_t length;
    uint32_t crc;                                            /* of all `length` bytes */
    uint32_t prefix_crc[SIGNATURE_AREA_MAX / SIGNATURE_GRAIN]; /* [k]: of the first 32 (k + 1) */
};

void signature_area_clear(struct signature_area *area);

/* Whether the `length` bytes at `offset` are those the area holds there: always for no bytes
 * inside it; for others when both ends of the piece lie on a 32-byte boundary or at the area's
 * end (as every piece a sender makes), and false for a piece cut elsewhere. */
bool signature_area_holds(const struct signature_area *area, uint32_t offset, const uint8_t *data,
                          uint32_t length);

/* Add `length` bytes at the area's end; the caller checked they fit SIGNATURE_AREA_MAX. */
void signature_area_append(struct signature_area *area, const uint8_t *data, uint32_t length);

#endif
