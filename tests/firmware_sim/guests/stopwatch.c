/*
 * stopwatch: a test module that reads the node's cycle counter (pbo_cycles) at the start of each
 * cycle and after a loop of 3 * n + 2 instructions, and outputs the start's low and high words
 * and the difference.
 */
#include "pbo_module.h"

enum { PORT_N, PORT_LOW, PORT_HIGH, PORT_LAP, PORT_COUNT };

/* 3 instructions per iteration, 2 more: the count is exact whatever the compiler does. */
__asm__(".section .text.spin\n"
        "spin:\n"
        "1: addi a0, a0, -1\n"
        "nop\n"
        "bnez a0, 1b\n"
        "ret\n");

int32_t spin(uint32_t n);

static int32_t stopwatch_cycle(struct pbo_context *ctx)
{
    const uint64_t start = pbo_cycles();
    spin(*(const uint32_t *)ctx->ports[PORT_N]);
    const uint64_t end = pbo_cycles();

    *(uint32_t *)ctx->ports[PORT_LOW] = (uint32_t)start;
    *(uint32_t *)ctx->ports[PORT_HIGH] = (uint32_t)(start >> 32);
    *(uint32_t *)ctx->ports[PORT_LAP] = (uint32_t)(end - start);
    return PBO_OK;
}

static const struct pbo_descriptor stopwatch_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "stopwatch",
    .ports = {
        [PORT_N] = {"n", PBO_PORT_CONST, PBO_SCALAR, sizeof(uint32_t), 1, 1},
        [PORT_LOW] = {"low", PBO_PORT_OUT, PBO_SCALAR, sizeof(uint32_t), 1, 1},
        [PORT_HIGH] = {"high", PBO_PORT_OUT, PBO_SCALAR, sizeof(uint32_t), 1, 1},
        [PORT_LAP] = {"lap", PBO_PORT_OUT, PBO_SCALAR, sizeof(uint32_t), 1, 1},
    },
    .cycle = stopwatch_cycle,
};

PBO_MODULE(stopwatch_descriptor)
