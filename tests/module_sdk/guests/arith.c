/*
 * Arithmetic that needs libgcc on RV32IM: float (soft float) and int64_t division, plus a
 * pbo_printf line. The tests load it at two addresses and compare the outputs with Python's.
 */
#include "pbo_module.h"
#include "pbo_printf.h"

enum { PORT_X, PORT_SCALED, PORT_QUOTIENT, PORT_REMAINDER, PORT_ROOT, PORT_COUNT };

/* Newton's square root in float: divisions, multiplications, conversions. */
static float root(float v)
{
    float r = v > 1.0f ? v / 2.0f : 1.0f;
    for (int i = 0; i < 20; i++) {
        r = 0.5f * (r + v / r);
    }
    return r;
}

static int32_t arith_cycle(struct pbo_context *ctx)
{
    const int32_t x = *(const int32_t *)ctx->ports[PORT_X];
    const float scaled = (float)x * 1.5f / 3.25f + 0.25f;
    const int64_t big = (int64_t)x * 1000000007LL;

    *(int32_t *)ctx->ports[PORT_SCALED] = (int32_t)(scaled * 1000.0f);
    *(int32_t *)ctx->ports[PORT_QUOTIENT] = (int32_t)(big / 12345LL);
    *(int32_t *)ctx->ports[PORT_REMAINDER] = (int32_t)((uint64_t)(big < 0 ? -big : big) % 977u);
    *(int32_t *)ctx->ports[PORT_ROOT] = (int32_t)(root((float)(x < 0 ? -x : x)) * 1000.0f);
    pbo_printf("arith: x=%d [%5d|%-4u|%04x|%X] q=%q r=%.2q s=%s%c%%", (int)x, -42, 7u, 0xBEEFu,
               0xABCDEFu, PBO_Q16(-1.5), PBO_Q16(3.14159), "ok", '!');
    return PBO_OK;
}

static const struct pbo_descriptor arith_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "arith",
    .ports = {
        [PORT_X] = {"x", PBO_PORT_IN, PBO_SCALAR, 4, 1, 1},
        [PORT_SCALED] = {"scaled", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1},
        [PORT_QUOTIENT] = {"quotient", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1},
        [PORT_REMAINDER] = {"remainder", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1},
        [PORT_ROOT] = {"root", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1},
    },
    .cycle = arith_cycle,
};

PBO_MODULE(arith_descriptor)
