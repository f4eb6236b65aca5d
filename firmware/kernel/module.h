/*
 * module.h - a registered module as the kernel keeps it: its decoded descriptor, where its
 * image is, and the layout of each instance's area (hexmigrate's Descriptor and the Python
 * node's GuestModule and AreaLayout).
 */
#ifndef KERNEL_MODULE_H
#define KERNEL_MODULE_H

#include <stdint.h>

#include "abi.h"

struct port_spec {
    char name[ABI_PORT_NAME_LEN + 1]; /* the Python node accepts a name filling all 12 bytes */
    uint8_t direction;                /* enum port_direction */
    uint8_t kind;                     /* enum port_kind */
    uint16_t element_size;            /* 1, 2 or 4 */
    uint16_t rows;
    uint16_t columns;
    uint32_t size; /* element_size * rows * columns bytes, set once the area fits */
};

/* Where the context, the state and each port buffer sit in an instance's area: offsets from
 * the area's start, each 8-byte aligned; `state` is 0 when the module has no state. */
struct area_layout {
    uint32_t state;
    uint32_t ports[ABI_MAX_PORTS];
    uint32_t size; /* the whole area, a multiple of 8 */
};

struct module {
    char name[ABI_NAME_LEN + 1]; /* likewise 16 characters at most */
    uint32_t state_size;
    uint32_t port_count;
    struct port_spec ports[ABI_MAX_PORTS];
    uint32_t methods[METHOD_COUNT]; /* guest addresses, 0 for an absent method */
    uint32_t image_base;
    uint32_t image_size;
    struct area_layout layout;
};

#endif /* KERNEL_MODULE_H */
