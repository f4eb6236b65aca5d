/*
 * node.h - the node's modules: what the protocol's receiver loads into (the Python node's
 * `Target`, hexmigrate/transfer/receiver.py).
 *
 * The flash directory is the commit point: a module belongs to the node once the directory lists
 * it, and the node boots with exactly the modules the directory lists whose images are intact,
 * whatever moment a power cut struck (docs/node.md, docs/firmware.md).
 */
#ifndef NODE_NODE_H
#define NODE_NODE_H

#include <stdbool.h>
#include <stdint.h>

#include "../kernel/text.h"
#include "flash_directory.h"
#include "loader.h"

struct installed_module {
    struct directory_entry entry;
    struct extent extent;
};

/* Read the directory and take back every intact module; `report` hears what was skipped. */
void node_boot(void (*report)(const char *line));

/* Make a verified image the node's module (replacing one of the same name): its name from its
 * descriptor, the kernel's consent, then the directory write. On failure the image is erased and
 * the old module stays; `why` says what failed. */
bool node_commit(const struct loaded_image *image, char *name, uint32_t *address,
                 struct text *why);

/* Remove module `name`: the directory first, then its flash. False when there is none. */
bool node_remove(const char *name, struct text *why);

uint32_t node_module_count(void);
const struct installed_module *node_module(uint32_t index);

/* "node: 1 module(s), ... free, qemu-virt firmware": the PONG line. */
void node_describe(struct text *line);

#endif
