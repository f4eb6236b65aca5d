/*
 * guest_memory.h - the one place where a 32-bit guest address becomes a kernel pointer.
 *
 * The module ABI is 32-bit: descriptors, contexts and service arguments hold guest addresses.
 * On RV32 a guest address is the address itself; on a 64-bit host (the kernel's tests) the
 * regions live in host buffers. The board maps each region once (its guest base, size and the
 * kernel's pointer to it); everything else in the kernel keeps addresses as uint32_t and reads
 * and writes through these functions, which also answer what a guest may do where
 * (docs/memory-map.md: flash r-x, SRAM r--, task window rw-, stack rw-).
 */
#ifndef KERNEL_GUEST_MEMORY_H
#define KERNEL_GUEST_MEMORY_H

#include <stdbool.h>
#include <stdint.h>

enum region_kind { REGION_FLASH, REGION_SRAM, REGION_WINDOW, REGION_STACK, REGION_COUNT };

enum guest_permission { GUEST_READ = 1, GUEST_WRITE = 2, GUEST_EXECUTE = 4 };

struct guest_region {
    const char *name; /* as the Python node names it in fault texts */
    uint32_t base;
    uint32_t size; /* 0: not mapped */
    uint8_t *host; /* the kernel's pointer to `base` */
    uint8_t guest; /* enum guest_permission bits */
};

/* Map a region: `size` bytes from guest address `base`, at `host` in the kernel's memory. */
void guest_memory_map(enum region_kind kind, uint32_t base, uint32_t size, void *host);
const struct guest_region *guest_memory_region(enum region_kind kind);

/* The region holding all `length` bytes at `address` (at least one byte), or NULL. */
const struct guest_region *guest_region_at(uint32_t address, uint32_t length);
/* "SRAM", "task window", ... or "unmapped memory": where an address lies, for fault texts. */
const char *guest_describe(uint32_t address);

bool guest_readable(uint32_t address, uint32_t length);
bool guest_writable(uint32_t address, uint32_t length);

/* The kernel's pointer to `length` bytes at `address` in one region, or NULL. The kernel's
 * own accesses are not bound by the guest's permissions, only by the regions. */
uint8_t *guest_bytes(uint32_t address, uint32_t length);

/* Little-endian fields; the caller checked the bytes are mapped. */
uint32_t guest_read32(uint32_t address);
uint16_t guest_read16(uint32_t address);
uint8_t guest_read8(uint32_t address);
void guest_write32(uint32_t address, uint32_t value);

/* Copy between mapped guest addresses (memmove semantics). */
void guest_copy(uint32_t destination, uint32_t source, uint32_t length);

#endif /* KERNEL_GUEST_MEMORY_H */
