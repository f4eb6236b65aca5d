/*
 * level_alarm - keeps a tank's level inside a band: opens the inlet valve below it.
 *
 * Ports: mm (input, the level in millimetres), valve (output, 1 = open the inlet), low and high
 * (constants: the band, in millimetres).
 * Evaluator: functional value 0 = how far the level is outside the band (mm, 0 inside it);
 * non-functional value 0 = power in mW. Estimator: the same on its own ports.
 */
#include "pbo_module.h"

enum { PORT_MM, PORT_VALVE, PORT_LOW, PORT_HIGH, PORT_COUNT };

#define IDLE_POWER_MILLI_MW 300u /* 0.3 mW while the module is loaded */
#define ENERGY_PER_CYCLE_NJ 40u  /* energy of one cycle: two compares and a port copy */

struct alarm_state {
    struct pbo_timing timing; /* the evaluator's cycle period */
};

static int32_t port(const struct pbo_context *ctx, int index)
{
    return *(const int32_t *)ctx->ports[index];
}

static int32_t alarm_init(struct pbo_context *ctx)
{
    struct alarm_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

/* Refuses to start without a band: high == 0 is the zero-filled constant, never set. */
static int32_t alarm_on(struct pbo_context *ctx)
{
    if (port(ctx, PORT_HIGH) <= port(ctx, PORT_LOW)) {
        PBO_LOG("level_alarm: expected low < high");
        return PBO_ERR_INVALID;
    }
    return PBO_OK;
}

static int32_t alarm_cycle(struct pbo_context *ctx)
{
    *(int32_t *)ctx->ports[PORT_VALVE] = port(ctx, PORT_MM) < port(ctx, PORT_LOW);
    return PBO_OK;
}

static int32_t alarm_off(struct pbo_context *ctx)
{
    struct alarm_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

/* How far the level is outside [low, high], in thousandths of a millimetre. */
static int32_t outside_milli(const struct pbo_context *ctx)
{
    int32_t mm = port(ctx, PORT_MM);
    int32_t below = port(ctx, PORT_LOW) - mm;
    int32_t above = mm - port(ctx, PORT_HIGH);
    int32_t outside = below > 0 ? below : (above > 0 ? above : 0);
    return outside * 1000;
}

static int32_t alarm_evaluate(struct pbo_context *ctx)
{
    struct alarm_state *s = ctx->state;
    const int32_t power = pbo_measure_power(&s->timing, IDLE_POWER_MILLI_MW, ENERGY_PER_CYCLE_NJ);

    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, 0, outside_milli(ctx));
    pbo_sys_perf_report(ctx, PBO_PERF_NON_FUNCTIONAL, PBO_POWER_INDEX, power);
    return PBO_OK;
}

static int32_t alarm_estimate(struct pbo_context *ctx)
{
    alarm_cycle(ctx);
    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, 0, outside_milli(ctx));
    return PBO_OK;
}

static const struct pbo_descriptor alarm_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "level_alarm",
    .state_size = sizeof(struct alarm_state),
    .ports = {
        [PORT_MM] = {"mm", PBO_PORT_IN, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_VALVE] = {"valve", PBO_PORT_OUT, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_LOW] = {"low", PBO_PORT_CONST, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_HIGH] = {"high", PBO_PORT_CONST, PBO_SCALAR, sizeof(int32_t), 1, 1},
    },
    .init = alarm_init,
    .on = alarm_on,
    .cycle = alarm_cycle,
    .off = alarm_off,
    .evaluate = alarm_evaluate,
    .estimate = alarm_estimate,
};

PBO_MODULE(alarm_descriptor)
