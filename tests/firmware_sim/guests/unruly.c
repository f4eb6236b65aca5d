/*
 * unruly: a test module that behaves (y = x + 1) for three cycles and then misbehaves the way
 * its configuration constant `mode` says, so the tests can check that the node stops exactly
 * that call, puts the PBO into ERROR and keeps every other PBO running.
 *
 * mode 1: write to flash      mode 2: write to SRAM (other modules' memory)
 * mode 3: endless loop        mode 4: write to the kernel page
 * mode 5: return an error     mode 9: refuse to initialise
 */
#include "pbo_module.h"

enum { PORT_X, PORT_Y, PORT_MODE, PORT_COUNT };

struct unruly_state {
    int32_t cycles;
};

static int32_t unruly_init(struct pbo_context *ctx)
{
    return *(const int32_t *)ctx->ports[PORT_MODE] == 9 ? PBO_ERR_INVALID : PBO_OK;
}

static int32_t unruly_cycle(struct pbo_context *ctx)
{
    struct unruly_state *s = ctx->state;
    const int32_t mode = *(const int32_t *)ctx->ports[PORT_MODE];

    s->cycles++;
    if (s->cycles > 3) {
        switch (mode) {
        case 1:
            *(volatile uint32_t *)0x08000000u = 0;
            break;
        case 2:
            *(volatile uint32_t *)0x20000040u = 0;
            break;
        case 3:
            for (;;) {
            }
        case 4:
            *(volatile uint32_t *)0x10000000u = 0;
            break;
        case 5:
            return PBO_ERR_INVALID;
        default:
            break;
        }
    }
    *(int32_t *)ctx->ports[PORT_Y] = *(const int32_t *)ctx->ports[PORT_X] + 1;
    return PBO_OK;
}

/* In ERROR the output goes to -1, so a test sees that outputs are copied after `error`. */
static int32_t unruly_error(struct pbo_context *ctx)
{
    *(int32_t *)ctx->ports[PORT_Y] = -1;
    return PBO_OK;
}

static int32_t unruly_clear(struct pbo_context *ctx)
{
    struct unruly_state *s = ctx->state;
    s->cycles = 0;
    return PBO_OK;
}

static const struct pbo_descriptor unruly_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "unruly",
    .state_size = sizeof(struct unruly_state),
    .ports = {
        [PORT_X] = {"x", PBO_PORT_IN, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_Y] = {"y", PBO_PORT_OUT, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_MODE] = {"mode", PBO_PORT_CONST, PBO_SCALAR, sizeof(int32_t), 1, 1},
    },
    .init = unruly_init,
    .cycle = unruly_cycle,
    .error = unruly_error,
    .clear = unruly_clear,
};

PBO_MODULE(unruly_descriptor)
