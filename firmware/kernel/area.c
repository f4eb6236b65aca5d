/* area.c - the layout of an instance's area (see area.h). */
#include "area.h"

#include "guest_memory.h"

uint64_t area_align(uint64_t value)
{
    return (value + AREA_ALIGNMENT - 1u) & ~(uint64_t)(AREA_ALIGNMENT - 1u);
}

/* Where the port buffers start: after the context, and the state when there is one. */
static uint64_t ports_start(const struct module *module)
{
    return area_align(area_align(ABI_CONTEXT_SIZE) + module->state_size);
}

uint64_t area_plan(struct module *module, uint32_t limit)
{
    uint64_t size = ports_start(module);

    for (uint32_t i = 0; i < module->port_count; i++) {
        const struct port_spec *port = &module->ports[i];
        size = area_align(size + (uint64_t)port->element_size * port->rows * port->columns);
    }
    if (size <= limit) {
        module->area_size = (uint32_t)size;
    }
    return size;
}

uint32_t area_packed(const struct module *module, uint32_t port, uint32_t directions)
{
    uint32_t offset = 0;

    for (uint32_t i = 0; i < port; i++) {
        if ((DIRECTIONS(module->ports[i].direction) & directions) != 0) {
            offset += (uint32_t)area_align(port_size(&module->ports[i]));
        }
    }
    return offset;
}

uint32_t area_port(const struct module *module, uint32_t port)
{
    return (uint32_t)ports_start(module) + area_packed(module, port, ALL_DIRECTIONS);
}

void area_write_context(const struct module *module, uint32_t base)
{
    const uint32_t state = base + (uint32_t)area_align(ABI_CONTEXT_SIZE);
    uint32_t next = base + (uint32_t)ports_start(module); /* the ports in order, as area_port */

    guest_write32(base, module->state_size != 0 ? state : 0);
    for (uint32_t i = 0; i < ABI_MAX_PORTS; i++) {
        uint32_t port = 0;
        if (i < module->port_count) {
            port = next;
            next += (uint32_t)area_align(port_size(&module->ports[i]));
        }
        guest_write32(base + 4u + 4u * i, port);
    }
}
