/*
 * signature_area.c - a signature area known by the CRC-32 of its prefixes (signature_area.h).
 */
#include "signature_area.h"

#include "../lib/crc.h"

void signature_area_clear(struct signature_area *area)
{
    area->length = 0;
    area->crc = 0;
}

/* The CRC of the area's first `end` bytes, when the node kept it. */
static bool prefix(const struct signature_area *area, uint64_t end, uint32_t *crc)
{
    if (end == area->length) {
        *crc = area->crc;
    } else if (end == 0) {
        *crc = 0;
    } else if (end < area->length && end % SIGNATURE_GRAIN == 0) {
        *crc = area->prefix_crc[end / SIGNATURE_GRAIN - 1];
    } else {
        return false;
    }
    return true;
}

bool signature_area_holds(const struct signature_area *area, uint32_t offset, const uint8_t *data,
                          uint32_t length)
{
    uint64_t end = (uint64_t)offset + length;
    if (end > area->length) {
        return false;
    }
    uint32_t before, after;
    if (length == 0) {
        return true;
    }
    return prefix(area, offset, &before) && prefix(area, end, &after) &&
           crc32_update(before, data, length) == after;
}

void signature_area_append(struct signature_area *area, const uint8_t *data, uint32_t length)
{
    while (length > 0) {
        uint32_t room = SIGNATURE_GRAIN - area->length % SIGNATURE_GRAIN;
        uint32_t taken = length < room ? length : room;
        area->crc = crc32_update(area->crc, data, taken);
        area->length += taken;
        if (area->length % SIGNATURE_GRAIN == 0) {
            area->prefix_crc[area->length / SIGNATURE_GRAIN - 1] = area->crc;
        }
        data += taken;
        length -= taken;
    }
}
