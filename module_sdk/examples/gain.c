/*
 * gain - multiplies its input by a configured gain: y = k * x, all three signed Q16.16.
 *
 * Ports: x (variable input), y (variable output), k (configuration constant). The product is
 * rounded to nearest and saturated to the int32 range.
 * Evaluator: functional value 0 = |y - k*x|, the output's error against the exact product (it
 * shows saturation); non-functional value 0 = power in mW from a per-cycle energy and the measured
 * cycle period. Estimator: the same computation on its own ports, then the functional value.
 */
#include "pbo_module.h"

enum { PORT_X, PORT_Y, PORT_K, PORT_COUNT };

#define IDLE_POWER_MILLI_MW 500u /* 0.5 mW while the module is loaded */
#define ENERGY_PER_CYCLE_NJ 60u  /* energy of one cycle: port copies and a multiply */

struct gain_state {
    struct pbo_timing timing; /* the evaluator's cycle period */
};

static int32_t gain_init(struct pbo_context *ctx)
{
    struct gain_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

/* Refuses to start unconfigured: k == 0 is the zero-filled constant port, never set.
 * Timing was reset by init or off. */
static int32_t gain_on(struct pbo_context *ctx)
{
    if (*(const int32_t *)ctx->ports[PORT_K] == 0) {
        PBO_LOG("gain: k is not configured");
        return PBO_ERR_INVALID;
    }
    return PBO_OK;
}

static int32_t gain_cycle(struct pbo_context *ctx)
{
    /* Port buffers are plain memory: the kernel copied the inputs in before this call and
       copies the outputs out after it, so direct access is safe and costs no service call. */
    *(int32_t *)ctx->ports[PORT_Y] =
        pbo_q16_mul(*(const int32_t *)ctx->ports[PORT_K], *(const int32_t *)ctx->ports[PORT_X]);

    return PBO_OK;
}

/* Switched off: the next on must not count the pause as a cycle period. */
static int32_t gain_off(struct pbo_context *ctx)
{
    struct gain_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

static int32_t gain_kill(struct pbo_context *ctx)
{
    (void)ctx;
    PBO_LOG("gain: killed");
    return PBO_OK;
}

/* A cycle failed: drive the output to 0, the safe value for an actuator further down. */
static int32_t gain_error(struct pbo_context *ctx)
{
    const int32_t zero = 0;
    PBO_LOG("gain: error, output forced to 0");
    return pbo_sys_port_write(ctx, PORT_Y, &zero, sizeof zero) == (int32_t)sizeof zero
               ? PBO_OK
               : PBO_ERR_INVALID;
}

/* Back to off: restart the period measurement, as off does. */
static int32_t gain_clear(struct pbo_context *ctx)
{
    struct gain_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

/* |y - k*x| in thousandths, from the port buffers as the last cycle left them. */
static int32_t output_error_milli(const struct pbo_context *ctx)
{
    int64_t x = *(const int32_t *)ctx->ports[PORT_X];
    int64_t k = *(const int32_t *)ctx->ports[PORT_K];
    int64_t y = *(const int32_t *)ctx->ports[PORT_Y];
    int64_t diff = y * PBO_Q16_ONE - k * x; /* Q32.32: exact */

    return pbo_milli_from_fixed((uint64_t)(diff < 0 ? -diff : diff), 2 * PBO_Q16_FRACTION_BITS);
}

/* Evaluator: observes the executor's context right after its cycle; only its timing changes. */
static int32_t gain_evaluate(struct pbo_context *ctx)
{
    struct gain_state *s = ctx->state;
    const int32_t power = pbo_measure_power(&s->timing, IDLE_POWER_MILLI_MW, ENERGY_PER_CYCLE_NJ);

    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, 0, output_error_milli(ctx));
    pbo_sys_perf_report(ctx, PBO_PERF_NON_FUNCTIONAL, PBO_POWER_INDEX, power);
    return PBO_OK;
}

/*
 * Estimator: runs the module's function on its own context (its own input, constant and output
 * ports) and reports the functional value; like the paper's E-PBO estimator it reports no
 * non-functional value, since only configurations known to be feasible are estimated.
 */
static int32_t gain_estimate(struct pbo_context *ctx)
{
    int32_t status = gain_cycle(ctx);
    if (status != PBO_OK) {
        return status;
    }
    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, 0, output_error_milli(ctx));
    return PBO_OK;
}

static const struct pbo_descriptor gain_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "gain",
    .state_size = sizeof(struct gain_state),
    .ports = {
        [PORT_X] = {"x", PBO_PORT_IN, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_Y] = {"y", PBO_PORT_OUT, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_K] = {"k", PBO_PORT_CONST, PBO_SCALAR, sizeof(int32_t), 1, 1},
    },
    .init = gain_init,
    .on = gain_on,
    .cycle = gain_cycle,
    .off = gain_off,
    .kill = gain_kill,
    .error = gain_error,
    .clear = gain_clear,
    .evaluate = gain_evaluate,
    .estimate = gain_estimate,
};

PBO_MODULE(gain_descriptor)
