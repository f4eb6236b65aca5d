/* guest_memory.c - guest addresses to kernel pointers, and the guest's permissions. */
#include "guest_memory.h"

#include "text.h"

static struct guest_region regions[REGION_COUNT] = {
    [REGION_FLASH] = {"flash", 0, 0, 0, GUEST_READ | GUEST_EXECUTE},
    [REGION_SRAM] = {"SRAM", 0, 0, 0, GUEST_READ},
    [REGION_WINDOW] = {"task window", 0, 0, 0, GUEST_READ | GUEST_WRITE},
    [REGION_STACK] = {"stack", 0, 0, 0, GUEST_READ | GUEST_WRITE},
};

void guest_memory_map(enum region_kind kind, uint32_t base, uint32_t size, void *host)
{
    regions[kind].base = base;
    regions[kind].size = size;
    regions[kind].host = host;
}

const struct guest_region *guest_memory_region(enum region_kind kind)
{
    return &regions[kind];
}

static bool contains(const struct guest_region *region, uint32_t address, uint32_t length)
{
    /* 64-bit sums: an address near 4 GiB plus a length must not wrap into a region */
    const uint64_t end = (uint64_t)region->base + region->size;
    const uint64_t last = (uint64_t)address + (length != 0 ? length : 1u);
    return region->size != 0 && region->base <= address && last <= end;
}

const struct guest_region *guest_region_at(uint32_t address, uint32_t length)
{
    for (uint32_t kind = 0; kind < REGION_COUNT; kind++) {
        if (contains(&regions[kind], address, length)) {
            return &regions[kind];
        }
    }
    return 0;
}

const char *guest_describe(uint32_t address)
{
    const struct guest_region *region = guest_region_at(address, 1);
    return region != 0 ? region->name : "unmapped memory";
}

bool guest_readable(uint32_t address, uint32_t length)
{
    const struct guest_region *region = guest_region_at(address, length);
    return region != 0 && (region->guest & GUEST_READ) != 0;
}

bool guest_writable(uint32_t address, uint32_t length)
{
    const struct guest_region *region = guest_region_at(address, length);
    return region != 0 && (region->guest & GUEST_WRITE) != 0;
}

uint8_t *guest_bytes(uint32_t address, uint32_t length)
{
    const struct guest_region *region = guest_region_at(address, length);
    return region != 0 ? region->host + (address - region->base) : 0;
}

uint32_t guest_read32(uint32_t address)
{
    const uint8_t *bytes = guest_bytes(address, 4);
    return (uint32_t)bytes[0] | (uint32_t)bytes[1] << 8 | (uint32_t)bytes[2] << 16 |
           (uint32_t)bytes[3] << 24;
}

uint16_t guest_read16(uint32_t address)
{
    const uint8_t *bytes = guest_bytes(address, 2);
    return (uint16_t)(bytes[0] | bytes[1] << 8);
}

uint8_t guest_read8(uint32_t address)
{
    return *guest_bytes(address, 1);
}

void guest_write32(uint32_t address, uint32_t value)
{
    uint8_t *bytes = guest_bytes(address, 4);
    for (uint32_t i = 0; i < 4; i++) {
        bytes[i] = (uint8_t)(value >> (8u * i));
    }
}

void guest_copy(uint32_t destination, uint32_t source, uint32_t length)
{
    if (length != 0) {
        bytes_copy(guest_bytes(destination, length), guest_bytes(source, length), length);
    }
}
