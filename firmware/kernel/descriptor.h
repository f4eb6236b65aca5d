/*
 * descriptor.h - reading and checking a module's descriptor, as the Python node does
 * (hexmigrate/descriptor.py decodes, firmware_sim/core/guest.py's Registrar checks).
 *
 * The checks run in the Python node's order, so the same bad descriptor gets the same status
 * on both nodes: magic and ABI version (STATUS_ERR_ABI); port count, names (C identifiers),
 * direction, type and shape of each port (STATUS_ERR_INVALID); a name already taken
 * (STATUS_ERR_EXISTS); distinct port names, method pointers 4-byte aligned inside the image
 * (STATUS_ERR_INVALID); an area that fits the task window and the largest free SRAM block
 * (STATUS_ERR_NO_MEMORY).
 */
#ifndef KERNEL_DESCRIPTOR_H
#define KERNEL_DESCRIPTOR_H

#include <stdbool.h>
#include <stdint.h>

#include "module.h"
#include "text.h"

/* Whether a module name is in use, for the STATUS_ERR_EXISTS check. */
typedef bool (*name_taken)(const char *name);

/*
 * Decode and check the descriptor at guest address `address`, which lies with its 224 bytes
 * inside the image `module->image_base`, `module->image_size` (the caller checked); an instance's
 * area must fit the task window and `largest_free`, the largest free SRAM block. Fills `module`
 * and returns STATUS_OK, or a negative status with the reason in `why`.
 */
int32_t descriptor_accept(uint32_t address, struct module *module, name_taken taken,
                          uint32_t largest_free, struct text *why);

/* "module image at 0x08000500..0x080007E3": the image, as the Python node names it. */
void descriptor_describe_image(struct text *text, uint32_t base, uint32_t size);

#endif /* KERNEL_DESCRIPTOR_H */
