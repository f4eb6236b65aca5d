/*
 * descriptor.c - finding a module's descriptor (descriptor.h). The checks are hexmigrate's
 * `Descriptor.decode`: magic, ABI version, at most 8 ports, identifiers for the module's and
 * the ports' names, and port shapes a kernel can hold.
 */
#include "descriptor.h"

#include "../board/board.h"

#define MAGIC 0x314F4250u /* "PBO1" */
#define ABI_VERSION 1u
#define MAX_PORTS 8u
#define PORT_SIZE 20u
#define PORTS_OFFSET 28u
#define PORT_NAME_LEN 12u

static uint32_t get16(const uint8_t *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8; }
static uint32_t get32(const uint8_t *p) { return get16(p) | get16(p + 2) << 16; }

/* A C identifier of at most `most` bytes, NUL-terminated within them or filling them. */
static bool identifier(const uint8_t *name, uint32_t most)
{
    uint32_t length = 0;
    while (length < most && name[length]) {
        uint8_t c = name[length];
        bool letter = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
        if (!letter && !(length && c >= '0' && c <= '9')) {
            return false;
        }
        length++;
    }
    return length > 0;
}

static bool port_ok(const uint8_t *port)
{
    uint32_t direction = port[12], type = port[13], element = get16(port + 14);
    uint32_t rows = get16(port + 16), columns = get16(port + 18);
    if (!identifier(port, PORT_NAME_LEN) || direction >= 4 || type >= 3) {
        return false;
    }
    if (element != 1 && element != 2 && element != 4) {
        return false;
    }
    if (rows < 1 || columns < 1) {
        return false;
    }
    return !(type == 0 && (rows != 1 || columns != 1)) && !(type == 1 && rows != 1);
}

static bool valid(const uint8_t *d)
{
    uint32_t ports = get16(d + 6);
    if (get32(d) != MAGIC || get16(d + 4) != ABI_VERSION || ports > MAX_PORTS ||
        !identifier(d + 8, DESCRIPTOR_NAME_LEN)) {
        return false;
    }
    for (uint32_t i = 0; i < ports; i++) {
        if (!port_ok(d + PORTS_OFFSET + i * PORT_SIZE)) {
            return false;
        }
    }
    return true;
}

bool descriptor_find_name(uint32_t offset, uint32_t size, uint32_t link_base,
                          char name[DESCRIPTOR_NAME_LEN + 1], struct text *why)
{
    uint8_t d[DESCRIPTOR_SIZE];
    uint32_t first = (4u - link_base % 4u) % 4u; /* the first 4-byte aligned link address */
    for (uint32_t position = first; size >= DESCRIPTOR_SIZE && position <= size - DESCRIPTOR_SIZE;
         position += 4) {
        uint8_t magic[4];
        board_flash_read(offset + position, magic, 4);
        if (get32(magic) != MAGIC) {
            continue;
        }
        board_flash_read(offset + position, d, DESCRIPTOR_SIZE);
        if (valid(d)) {
            uint32_t i = 0;
            for (; i < DESCRIPTOR_NAME_LEN && d[8 + i]; i++) {
                name[i] = (char)d[8 + i];
            }
            name[i] = '\0';
            return true;
        }
    }
    text_add(why, "expected a PBO descriptor (magic PBO1, ABI version 1) in the image, got "
                    "none: it is no module the node can register");
    return false;
}
