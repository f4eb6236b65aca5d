/*
 * Kalman - a one-dimensional Kalman filter of the rover's offset from the line.
 *
 * The offset is modelled as a random walk (process noise q, mm^2 per cycle) measured with noise
 * (r, mm^2). Each cycle predicts (p += q), takes the gain k = p / (p + r) in 1/4096ths, corrects
 * the estimate by k times the innovation, and shrinks p by (1 - k). The estimate keeps 8
 * fractional bits; every product fits 32 bits (p is clamped), and there is no 64-bit division,
 * which a module without libgcc cannot call.
 *
 * Ports: raw (input, mm), offset (output, mm), q and r (constants, mm^2, both > 0).
 * Evaluator: functional 0 = |innovation| in mm (how far the measurements jump from the estimate);
 * non-functional 0 = power (thousandths of a mW), 1 = CPU load (percent, in thousandths).
 * Estimator: the cycle on its own ports, then the same functional report.
 */
#include "pbo_module.h"

enum { PORT_RAW, PORT_OFFSET, PORT_Q, PORT_R, PORT_COUNT };

#define IDLE_POWER_MILLI_MW 400u /* 0.4 mW while loaded */
#define ENERGY_PER_CYCLE_NJ 90u  /* a division and a few products */
#define CPU_LOAD_MILLI 35000     /* 35 % of a node: its share in the module database */
#define GAIN_ONE 4096            /* the gain's unit */
#define P_LIMIT 400000           /* mm^2: keeps p * GAIN_ONE within 31 bits */

struct kalman_state {
    struct pbo_timing timing;
    int32_t estimate_q8; /* mm, 8 fractional bits */
    int32_t p;           /* estimate variance, mm^2 */
    int32_t innovation;  /* mm, the last one */
    int32_t primed;      /* the first measurement was taken as the estimate */
};

static int32_t port(const struct pbo_context *ctx, int index)
{
    return *(const int32_t *)ctx->ports[index];
}

static void reset(struct kalman_state *s)
{
    pbo_timing_reset(&s->timing);
    s->estimate_q8 = 0;
    s->p = 0;
    s->innovation = 0;
    s->primed = 0;
}

static int32_t kalman_init(struct pbo_context *ctx)
{
    reset(ctx->state);
    return PBO_OK;
}

/* Refuses to start without its noise figures: 0 is the zero-filled constant, never set. */
static int32_t kalman_on(struct pbo_context *ctx)
{
    if (port(ctx, PORT_Q) <= 0 || port(ctx, PORT_R) <= 0) {
        PBO_LOG("Kalman: expected q > 0 and r > 0");
        return PBO_ERR_INVALID;
    }
    return PBO_OK;
}

static int32_t kalman_cycle(struct pbo_context *ctx)
{
    struct kalman_state *s = ctx->state;
    const int32_t raw = port(ctx, PORT_RAW);

    if (!s->primed) {
        s->estimate_q8 = raw * 256;
        s->p = port(ctx, PORT_R);
        s->primed = 1;
    }
    s->p += port(ctx, PORT_Q);
    if (s->p > P_LIMIT) {
        s->p = P_LIMIT;
    }
    const int32_t gain = (s->p * GAIN_ONE) / (s->p + port(ctx, PORT_R));
    s->innovation = raw - s->estimate_q8 / 256;
    s->estimate_q8 += (gain * (raw * 256 - s->estimate_q8)) / GAIN_ONE;
    s->p = (s->p * (GAIN_ONE - gain)) / GAIN_ONE;
    *(int32_t *)ctx->ports[PORT_OFFSET] = s->estimate_q8 / 256;
    return PBO_OK;
}

static int32_t kalman_off(struct pbo_context *ctx)
{
    reset(ctx->state);
    return PBO_OK;
}

static int32_t magnitude(int32_t value)
{
    return value < 0 ? -value : value;
}

static int32_t kalman_evaluate(struct pbo_context *ctx)
{
    struct kalman_state *s = ctx->state;
    const int32_t power = pbo_measure_power(&s->timing, IDLE_POWER_MILLI_MW, ENERGY_PER_CYCLE_NJ);

    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, 0, magnitude(s->innovation) * 1000);
    pbo_sys_perf_report(ctx, PBO_PERF_NON_FUNCTIONAL, PBO_POWER_INDEX, power);
    pbo_sys_perf_report(ctx, PBO_PERF_NON_FUNCTIONAL, 1, CPU_LOAD_MILLI);
    return PBO_OK;
}

static int32_t kalman_estimate(struct pbo_context *ctx)
{
    struct kalman_state *s = ctx->state;
    kalman_cycle(ctx);
    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, 0, magnitude(s->innovation) * 1000);
    return PBO_OK;
}

static const struct pbo_descriptor kalman_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "Kalman",
    .state_size = sizeof(struct kalman_state),
    .ports = {
        [PORT_RAW] = {"raw", PBO_PORT_IN, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_OFFSET] = {"offset", PBO_PORT_OUT, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_Q] = {"q", PBO_PORT_CONST, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_R] = {"r", PBO_PORT_CONST, PBO_SCALAR, sizeof(int32_t), 1, 1},
    },
    .init = kalman_init,
    .on = kalman_on,
    .cycle = kalman_cycle,
    .off = kalman_off,
    .evaluate = kalman_evaluate,
    .estimate = kalman_estimate,
};

PBO_MODULE(kalman_descriptor)
