/*
 * hog: a test module whose cycle runs 3 * n + 6 instructions (n its configuration constant) and
 * does nothing else, so a test can make one PBO's job longer than its period.
 */
#include "pbo_module.h"

enum { PORT_N, PORT_COUNT };

/* 3 instructions per iteration: the count is exact whatever the compiler does around it. */
__asm__(".section .text.burn\n"
        "burn:\n"
        "1: addi a0, a0, -1\n"
        "nop\n"
        "bnez a0, 1b\n"
        "ret\n");

int32_t burn(uint32_t n);

static int32_t hog_cycle(struct pbo_context *ctx)
{
    burn(*(const uint32_t *)ctx->ports[PORT_N]);
    return PBO_OK;
}

static const struct pbo_descriptor hog_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "hog",
    .ports = {
        [PORT_N] = {"n", PBO_PORT_CONST, PBO_SCALAR, sizeof(uint32_t), 1, 1},
    },
    .cycle = hog_cycle,
};

PBO_MODULE(hog_descriptor)
