/*
 * module.h - a registered module as the kernel keeps it: its decoded descriptor, where its
 * image is, and the size of each instance's area (hexmigrate's Descriptor and the Python
 * node's GuestModule). Where each part of an area sits follows from the ports (area.h): the
 * kernel derives it rather than keeping a copy per PBO in RAM.
 */
#ifndef KERNEL_MODULE_H
#define KERNEL_MODULE_H

#include <stdint.h>

#include "abi.h"

struct port_spec {
    char name[ABI_PORT_NAME_LEN + 1]; /* the Python node accepts a name filling all 12 bytes */
    uint8_t direction;                /* enum port_direction */
    uint8_t kind;                     /* enum port_kind */
    uint8_t element_size;             /* 1, 2 or 4 */
    uint16_t rows;
    uint16_t columns;
};

struct module {
    char name[ABI_NAME_LEN + 1]; /* likewise 16 characters at most */
    uint8_t port_count;          /* at most ABI_MAX_PORTS */
    uint32_t state_size;
    struct port_spec ports[ABI_MAX_PORTS];
    uint32_t methods[METHOD_COUNT]; /* guest addresses, 0 for an absent method */
    uint32_t image_base;
    uint32_t image_size;
    uint32_t area_size; /* an instance's area (area.h), a multiple of 8 */
};

/* A port's buffer: element_size * rows * columns bytes. Only for a module whose area fits
 * (area_plan), so that the product fits 32 bits. */
static inline uint32_t port_size(const struct port_spec *port)
{
    return (uint32_t)port->element_size * port->rows * port->columns;
}

#endif /* KERNEL_MODULE_H */
