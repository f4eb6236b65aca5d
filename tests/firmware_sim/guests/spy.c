/*
 * spy: a test module whose cycle records, before it does anything else, every register a call
 * does not set (all but ra, sp and a0) into its output `seen`, so a test can check that no value
 * of the module that ran before it reaches it.
 */
#include "pbo_module.h"

enum { PORT_SEEN, PORT_COUNT };
#define REGISTERS 28

int32_t spy_record(struct pbo_context *ctx, const uint32_t *saved);

/* The registers in the order x3, x4, ..., x31 without x10 (a0). */
__asm__(".section .text.spy_cycle\n"
        "spy_cycle:\n"
        "addi sp, sp, -128\n"
        "sw ra, 124(sp)\n"
        "sw x3, 0(sp)\nsw x4, 4(sp)\nsw x5, 8(sp)\nsw x6, 12(sp)\nsw x7, 16(sp)\n"
        "sw x8, 20(sp)\nsw x9, 24(sp)\nsw x11, 28(sp)\nsw x12, 32(sp)\nsw x13, 36(sp)\n"
        "sw x14, 40(sp)\nsw x15, 44(sp)\nsw x16, 48(sp)\nsw x17, 52(sp)\nsw x18, 56(sp)\n"
        "sw x19, 60(sp)\nsw x20, 64(sp)\nsw x21, 68(sp)\nsw x22, 72(sp)\nsw x23, 76(sp)\n"
        "sw x24, 80(sp)\nsw x25, 84(sp)\nsw x26, 88(sp)\nsw x27, 92(sp)\nsw x28, 96(sp)\n"
        "sw x29, 100(sp)\nsw x30, 104(sp)\nsw x31, 108(sp)\n"
        "mv a1, sp\n"
        "call spy_record\n"
        "lw ra, 124(sp)\n"
        "addi sp, sp, 128\n"
        "ret\n");

int32_t spy_cycle(struct pbo_context *ctx);

int32_t spy_record(struct pbo_context *ctx, const uint32_t *saved)
{
    uint32_t *seen = ctx->ports[PORT_SEEN];
    for (uint32_t i = 0; i < REGISTERS; i++) {
        seen[i] = saved[i];
    }
    return PBO_OK;
}

static const struct pbo_descriptor spy_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "spy",
    .ports = {
        [PORT_SEEN] = {"seen", PBO_PORT_OUT, PBO_VECTOR, sizeof(int32_t), 1, REGISTERS},
    },
    .cycle = spy_cycle,
};

PBO_MODULE(spy_descriptor)
