/*
 * A module that fails on request, to check that its faults name their source line: `mode` 1
 * writes outside the task window, 2 spins into the watchdog, and `on` refuses when `refuse` is
 * set. The tests find the lines by the marker comments.
 */
#include "pbo_module.h"

enum { PORT_MODE, PORT_REFUSE, PORT_COUNT };

static int32_t faulty_cycle(struct pbo_context *ctx)
{
    const uint32_t mode = *(const volatile uint32_t *)ctx->ports[PORT_MODE];
    if (mode == 1u) {
        *(volatile uint32_t *)(uintptr_t)0x20000010u = mode; /* MARK: write */
    }
    while (mode == 2u) {
        *(volatile uint32_t *)ctx->ports[PORT_MODE] = mode; /* MARK: spin */
    }
    return PBO_OK;
}

static int32_t faulty_on(struct pbo_context *ctx) /* MARK: on */
{
    return *(const volatile uint32_t *)ctx->ports[PORT_REFUSE] ? -3 : PBO_OK;
}

static const struct pbo_descriptor faulty_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "faulty",
    .ports = {
        [PORT_MODE] = {"mode", PBO_PORT_CONST, PBO_SCALAR, 4, 1, 1},
        [PORT_REFUSE] = {"refuse", PBO_PORT_CONST, PBO_SCALAR, 4, 1, 1},
    },
    .cycle = faulty_cycle,
    .on = faulty_on,
};

PBO_MODULE(faulty_descriptor)
