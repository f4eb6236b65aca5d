/*
 * fake_module.h - a module's descriptor written as the SDK lays it out, for host tests where
 * module code is C: the kernel's host driver (host_driver.c) and the node harness
 * (firmware/host/node_harness.c) register modules made of a descriptor in flash and C fakes.
 */
#ifndef KERNEL_TESTS_FAKE_MODULE_H
#define KERNEL_TESTS_FAKE_MODULE_H

#include <stdint.h>

#define FAKE_DESCRIPTOR 0x100u /* where the descriptor sits in a fake module's image */
#define FAKE_IMAGE_SIZE 0x200u /* the image: a word per method before it, the descriptor */

struct fake_port {
    const char *name;
    uint8_t direction, kind;
    uint16_t size, rows, columns;
};

/* Write into `image` (FAKE_IMAGE_SIZE bytes, linked at guest address `base`) the descriptor of
 * module `name`: its state size, its ports, and for each method in the bitmask `methods` the
 * address base + 4 * (method + 1), where a test registers the method's C fake. */
void fake_module_image(uint8_t *image, uint32_t base, const char *name, uint32_t state_size,
                       const struct fake_port *ports, uint32_t count, uint32_t methods);

/* Little-endian 16- and 32-bit values at `at`, as the descriptor holds them (a test damages
 * a descriptor with them). */
void fake_put16(uint8_t *at, uint16_t v);
void fake_put32(uint8_t *at, uint32_t v);

/* The guest address of method `method` of the fake module linked at `base`. */
uint32_t fake_module_method(uint32_t base, uint32_t method);

#endif /* KERNEL_TESTS_FAKE_MODULE_H */
