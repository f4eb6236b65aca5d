/* area.c - the layout of an instance's area (see area.h). */
#include "area.h"

#include "guest_memory.h"

uint64_t area_align(uint64_t value)
{
    return (value + AREA_ALIGNMENT - 1u) & ~(uint64_t)(AREA_ALIGNMENT - 1u);
}

static uint64_t port_bytes(const struct port_spec *port)
{
    return (uint64_t)port->element_size * port->rows * port->columns;
}

uint64_t area_plan(struct module *module, uint32_t limit)
{
    uint64_t offsets[ABI_MAX_PORTS];
    uint64_t offset = area_align(ABI_CONTEXT_SIZE);
    uint64_t state = 0;

    if (module->state_size != 0) {
        state = offset;
        offset = area_align(offset + module->state_size);
    }
    for (uint32_t i = 0; i < module->port_count; i++) {
        offsets[i] = offset;
        offset = area_align(offset + port_bytes(&module->ports[i]));
    }
    if (offset <= limit) {
        module->layout.state = (uint32_t)state;
        for (uint32_t i = 0; i < module->port_count; i++) {
            module->layout.ports[i] = (uint32_t)offsets[i];
            module->ports[i].size = (uint32_t)port_bytes(&module->ports[i]);
        }
        module->layout.size = (uint32_t)offset;
    }
    return offset;
}

void area_write_context(const struct module *module, uint32_t base)
{
    const struct area_layout *layout = &module->layout;

    guest_write32(base, layout->state != 0 ? base + layout->state : 0);
    for (uint32_t i = 0; i < ABI_MAX_PORTS; i++) {
        guest_write32(base + 4u + 4u * i, i < module->port_count ? base + layout->ports[i] : 0);
    }
}
