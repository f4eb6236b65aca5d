/* fake_module.c - a fake module's descriptor bytes (fake_module.h). */
#include "fake_module.h"

#include <string.h>

#include "../abi.h"

void fake_put16(uint8_t *at, uint16_t v)
{
    at[0] = (uint8_t)v;
    at[1] = (uint8_t)(v >> 8);
}

void fake_put32(uint8_t *at, uint32_t v)
{
    fake_put16(at, (uint16_t)v);
    fake_put16(at + 2, (uint16_t)(v >> 16));
}

uint32_t fake_module_method(uint32_t base, uint32_t method)
{
    return base + 4u * (method + 1u);
}

void fake_module_image(uint8_t *image, uint32_t base, const char *name, uint32_t state_size,
                       const struct fake_port *ports, uint32_t count, uint32_t methods)
{
    uint8_t *d = image + FAKE_DESCRIPTOR;
    fake_put32(d, ABI_MAGIC);
    fake_put16(d + 4, ABI_VERSION);
    fake_put16(d + 6, (uint16_t)count);
    memcpy(d + 8, name, strlen(name));
    fake_put32(d + 24, state_size);
    for (uint32_t i = 0; i < count; i++) {
        uint8_t *p = d + 28 + 20 * i;
        memcpy(p, ports[i].name, strlen(ports[i].name));
        p[12] = ports[i].direction;
        p[13] = ports[i].kind;
        fake_put16(p + 14, ports[i].size);
        fake_put16(p + 16, ports[i].rows);
        fake_put16(p + 18, ports[i].columns);
    }
    for (uint32_t i = 0; i < METHOD_COUNT; i++) {
        fake_put32(d + 188 + 4 * i, methods & (1u << i) ? fake_module_method(base, i) : 0u);
    }
}
