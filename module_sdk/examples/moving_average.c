/*
 * moving_average - smooths its input: y = mean of the last 8 samples of x, signed Q16.16.
 *
 * Ports: x (variable input), y (variable output). The window is a ring buffer in ctx->state;
 * the first sample after on or error fills the whole window, so the output starts at the
 * input instead of ramping up from 0.
 * Evaluator: functional value 0 = the mean absolute deviation of the window from y (how much the
 * filter smooths away: large when the input is noisy); non-functional value 0 = power in mW from
 * a per-cycle energy and the measured cycle period. Estimator: the same filter on its own context
 * and ports, then the functional value.
 */
#include "pbo_module.h"

enum { PORT_X, PORT_Y, PORT_COUNT };

#define WINDOW_LOG2 3u             /* a power of two: the ring index wraps with a mask */
#define WINDOW (1u << WINDOW_LOG2) /* 8 samples */
#define IDLE_POWER_MILLI_MW 500u   /* 0.5 mW while the module is loaded */
#define ENERGY_PER_CYCLE_NJ 90u    /* energy of one cycle: port copies and a sum of 8 samples */

struct ma_state {
    int32_t window[WINDOW];   /* the latest samples; meaningless until primed */
    struct pbo_timing timing; /* the evaluator's cycle period */
    uint8_t next;             /* ring index the next sample goes to */
    uint8_t primed;           /* the window holds samples */
};

/* Forget the samples: the next one fills the window. */
static void reset_window(struct ma_state *s)
{
    s->next = 0;
    s->primed = 0;
}

static int32_t window_mean(const struct ma_state *s)
{
    int64_t sum = 0;
    for (uint32_t i = 0; i < WINDOW; i++) {
        sum += s->window[i];
    }
    /* / WINDOW rounded, as a shift: a 64-bit divide would need libgcc, which modules lack */
    return (int32_t)((sum + WINDOW / 2) >> WINDOW_LOG2);
}

static int32_t ma_init(struct pbo_context *ctx)
{
    struct ma_state *s = ctx->state;
    reset_window(s);
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

/* Each run starts from fresh samples: old ones may be from long ago. Timing was reset by off. */
static int32_t ma_on(struct pbo_context *ctx)
{
    reset_window(ctx->state);
    return PBO_OK;
}

static int32_t ma_cycle(struct pbo_context *ctx)
{
    struct ma_state *s = ctx->state;
    int32_t y;
    /* Port buffers are plain memory, copied in before the call and out after it. The checked
       service (pbo_sys_port_read) would do the same at the cost of a kernel call. */
    const int32_t x = *(const int32_t *)ctx->ports[PORT_X];

    if (!s->primed) {
        for (uint32_t i = 0; i < WINDOW; i++) {
            s->window[i] = x;
        }
        s->primed = 1;
    }
    s->window[s->next] = x;
    s->next = (s->next + 1u) & (WINDOW - 1u);
    y = window_mean(s);
    *(int32_t *)ctx->ports[PORT_Y] = y;

    return PBO_OK;
}

/* Switched off: the next on must not count the pause as a cycle period. */
static int32_t ma_off(struct pbo_context *ctx)
{
    struct ma_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

static int32_t ma_kill(struct pbo_context *ctx)
{
    (void)ctx;
    PBO_LOG("moving_average: killed");
    return PBO_OK;
}

/* A cycle failed: the window may hold a bad sample, so drop it. */
static int32_t ma_error(struct pbo_context *ctx)
{
    PBO_LOG("moving_average: error, window dropped");
    reset_window(ctx->state);
    return PBO_OK;
}

/* Back to off: error already dropped the window; restart the period measurement like off. */
static int32_t ma_clear(struct pbo_context *ctx)
{
    struct ma_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

/* Mean |window[i] - y| in thousandths, from the state and output port the last cycle left. */
static int32_t deviation_milli(const struct pbo_context *ctx)
{
    const struct ma_state *s = ctx->state;
    int64_t y = *(const int32_t *)ctx->ports[PORT_Y];
    uint64_t total = 0;

    if (!s->primed) {
        return 0;
    }
    for (uint32_t i = 0; i < WINDOW; i++) {
        int64_t diff = s->window[i] - y;
        total += (uint64_t)(diff < 0 ? -diff : diff);
    }
    /* the total in Q16.16 with WINDOW_LOG2 more fraction bits is the mean */
    return pbo_milli_from_fixed(total, PBO_Q16_FRACTION_BITS + WINDOW_LOG2);
}

/* Evaluator: observes the executor's context right after its cycle; only its timing changes. */
static int32_t ma_evaluate(struct pbo_context *ctx)
{
    struct ma_state *s = ctx->state;
    const int32_t power = pbo_measure_power(&s->timing, IDLE_POWER_MILLI_MW, ENERGY_PER_CYCLE_NJ);

    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, 0, deviation_milli(ctx));
    pbo_sys_perf_report(ctx, PBO_PERF_NON_FUNCTIONAL, PBO_POWER_INDEX, power);
    return PBO_OK;
}

/*
 * Estimator: runs the filter on its own context (its own window and ports) and reports the
 * functional value; like the paper's E-PBO estimator it reports no non-functional value, since
 * only configurations known to be feasible are estimated.
 */
static int32_t ma_estimate(struct pbo_context *ctx)
{
    int32_t status = ma_cycle(ctx);
    if (status != PBO_OK) {
        return status;
    }
    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, 0, deviation_milli(ctx));
    return PBO_OK;
}

static const struct pbo_descriptor ma_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "moving_average",
    .state_size = sizeof(struct ma_state),
    .ports = {
        [PORT_X] = {"x", PBO_PORT_IN, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_Y] = {"y", PBO_PORT_OUT, PBO_SCALAR, sizeof(int32_t), 1, 1},
    },
    .init = ma_init,
    .on = ma_on,
    .cycle = ma_cycle,
    .off = ma_off,
    .kill = ma_kill,
    .error = ma_error,
    .clear = ma_clear,
    .evaluate = ma_evaluate,
    .estimate = ma_estimate,
};

PBO_MODULE(ma_descriptor)
