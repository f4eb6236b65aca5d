/*
 * descriptor.h - the module's name, read from its PBO descriptor in flash.
 *
 * A module file carries no name: a module is called what its descriptor says (`struct
 * pbo_descriptor` of module_sdk/pbo_module.h, magic "PBO1", ABI 1), the first valid one at a
 * 4-byte aligned link address, as hexmigrate's `find_descriptor` picks it. The node names the
 * module at COMMIT from the image as it sits in flash, before any of its code runs.
 */
#ifndef NODE_DESCRIPTOR_H
#define NODE_DESCRIPTOR_H

#include <stdbool.h>
#include <stdint.h>

#include "../kernel/text.h"

#define DESCRIPTOR_NAME_LEN 16
#define DESCRIPTOR_SIZE 224

/* The name in the first valid descriptor of the image at flash `offset` (`size` bytes, linked
 * at `link_base`); false with the reason when there is none. */
bool descriptor_find_name(uint32_t offset, uint32_t size, uint32_t link_base,
                          char name[DESCRIPTOR_NAME_LEN + 1], struct text *why);

#endif
