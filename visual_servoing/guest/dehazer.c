/*
 * dehazer - removes noise from a grey camera frame and restores its contrast: the paper's Dehazer
 * E-PBO (section 6.4), which ReFrESH migrates to a node whose camera went noisy.
 *
 * Ports: raw (variable input) and image (variable output), frames of ROWS x COLUMNS uint8 grey
 * levels, row after row.
 *
 * cycle, in two passes over the frame:
 *   1. a 3x3 median with replicated edges (the centre pixel's row and column stand in for the
 *      missing neighbours, as OpenCV's medianBlur does): it removes salt-and-pepper noise and
 *      reduces Gaussian noise. The same pass counts the median image's histogram and sums
 *      |raw - median|, the noise it removed.
 *   2. a contrast stretch: `low` and `high` are the grey levels of rank CLIP_RANK and
 *      PIXELS - 1 - CLIP_RANK of the median image (its 1st and 99th percentiles); levels map
 *      linearly from [low, high] onto [0, 255], rounded, clipped below and above. That undoes
 *      fog, which pulls every level towards a grey. When high - low < MIN_SPREAD (a blank or
 *      black frame) there is no contrast to restore and stretching would only amplify noise, so
 *      the levels stay as they are.
 * visual_servoing/dehaze.py is the same algorithm in numpy; tests require byte-identical output.
 *
 * Evaluator (after each cycle, from the state the cycle left): functional value 0 = the output's
 * contrast, in grey levels (255 once restored, less on a frame too flat to restore); 1 = the
 * input's contrast after noise removal (high - low: small under fog); 2 = the mean noise removed
 * per pixel, mean |raw - median| in grey levels (large on a noisy camera). Non-functional value 0
 * = power in mW from an energy per frame and the measured cycle period. Estimator: the same cycle
 * on its own context and ports, then the three functional values.
 *
 * Speed (benchmarks/dehazer.py): about 1.6 M instructions a frame. The emulated core costs real
 * time per instruction and the node's counting hook per translated block, so the loops are
 * branch-free (min and max by masks: RV32IM has no min/max instruction), the median works on
 * pairs of pixels whose windows share two sorted columns, and the percentiles and the stretch
 * table are sums and clamps rather than searches.
 */
/* The SDK builds for size (-Os); this module's loops want speed. -O2 would turn the histogram's
 * emptying into a memset call, which a module cannot make: no loop-to-library patterns. */
#pragma GCC optimize("O2", "no-tree-loop-distribute-patterns")
#include "pbo_module.h"

enum { PORT_RAW, PORT_IMAGE, PORT_COUNT };

#define ROWS 120u
#define COLUMNS 160u
#define PIXELS (ROWS * COLUMNS)
#define LEVELS 256u
#define WHITE 255u
#define CLIP_PERMILLE 10u                          /* 1 % of the pixels clip at each end */
#define CLIP_RANK (PIXELS * CLIP_PERMILLE / 1000u) /* rank of the low percentile: 192 */
#define MIN_SPREAD 16u                             /* flatter frames are not stretched */
#define MILLI 1000u
/* Helpers of the inner loop: -O2 alone would still call some of them. */
#define INLINE static inline __attribute__((always_inline))

_Static_assert(COLUMNS % 2u == 0u, "the median works on pairs of pixels");

#define IDLE_POWER_MILLI_MW 500u /* 0.5 mW while the module is loaded */
/* Energy of one frame: about 1.6 M instructions at 0.1 nJ each (a 100 MHz core drawing 10 mW). */
#define ENERGY_PER_FRAME_NJ 160000u

enum { PERF_OUTPUT_CONTRAST, PERF_INPUT_CONTRAST, PERF_NOISE_REMOVED };

struct dehazer_state {
    uint32_t histogram[LEVELS]; /* of the median image; all zero between cycles */
    uint32_t noise_sum;         /* sum of |raw - median| over the latest frame */
    uint32_t low;               /* the latest frame's low percentile (after the median) */
    uint32_t high;              /* its high percentile */
    uint32_t output_low;        /* where the stretch mapped low and high */
    uint32_t output_high;
    struct pbo_timing timing;   /* the evaluator's cycle period */
    uint8_t lut[LEVELS];        /* the latest stretch: median level -> output level */
};

/* One sorted column of a 3x3 window. */
struct column {
    uint32_t lo, mid, hi;
};

/* Orders two grey levels without a branch: d & (d >> 31) is a - b when a < b, else 0. */
INLINE void sort2(uint32_t *a, uint32_t *b)
{
    const int32_t d = (int32_t)(*a - *b);
    const uint32_t m = (uint32_t)(d & (d >> 31));
    const uint32_t smaller = *b + m;
    *b = *a - m;
    *a = smaller;
}

INLINE uint32_t lesser(uint32_t a, uint32_t b)
{
    const int32_t d = (int32_t)(a - b);
    return b + (uint32_t)(d & (d >> 31));
}

INLINE uint32_t greater(uint32_t a, uint32_t b)
{
    const int32_t d = (int32_t)(a - b);
    return a - (uint32_t)(d & (d >> 31));
}

INLINE uint32_t median3(uint32_t a, uint32_t b, uint32_t c)
{
    sort2(&a, &b);
    return greater(a, lesser(b, c));
}

INLINE struct column sorted_column(uint32_t a, uint32_t b, uint32_t c)
{
    sort2(&a, &b);
    sort2(&b, &c);
    sort2(&a, &b);
    return (struct column){a, b, c};
}

/* The medians of the two windows centred on columns 1 and 2 of four sorted columns 0..3.
 * The median of nine is the median of the largest low, the middle middle and the smallest high
 * of its three sorted columns (every level below that largest low, or above that smallest high,
 * has at least five levels on its other side). Neighbouring windows share two columns, so the
 * shared halves of those three are worked out once. */
INLINE void median_pair(struct column c0, struct column c1, struct column c2, struct column c3,
                        uint32_t *first, uint32_t *second)
{
    const uint32_t lo = greater(c1.lo, c2.lo);
    const uint32_t hi = lesser(c1.hi, c2.hi);
    uint32_t mid_lo = c1.mid;
    uint32_t mid_hi = c2.mid;

    /* then the median of mid_lo, mid_hi and m is max(mid_lo, min(mid_hi, m)) */
    sort2(&mid_lo, &mid_hi);
    *first = median3(greater(c0.lo, lo), greater(mid_lo, lesser(mid_hi, c0.mid)),
                     lesser(c0.hi, hi));
    *second = median3(greater(lo, c3.lo), greater(mid_lo, lesser(mid_hi, c3.mid)),
                      lesser(hi, c3.hi));
}

INLINE uint32_t abs_diff(uint32_t a, uint32_t b)
{
    const int32_t d = (int32_t)(a - b);
    const int32_t sign = d >> 31;
    return (uint32_t)((d ^ sign) - sign);
}

/* Writes the median pixels at x and x + 1, counts them in the histogram, returns the noise they
 * removed. */
INLINE uint32_t emit_pair(struct column c0, struct column c1, struct column c2, struct column c3,
                          const uint8_t *at, uint8_t *out, uint32_t *histogram)
{
    uint32_t first;
    uint32_t second;

    median_pair(c0, c1, c2, c3, &first, &second);
    out[0] = (uint8_t)first;
    out[1] = (uint8_t)second;
    histogram[first]++;
    histogram[second]++;
    return abs_diff(at[0], first) + abs_diff(at[1], second);
}

/* One row of the median image from the rows above, at and below it, two pixels at a time. */
static uint32_t median_row(const uint8_t *up, const uint8_t *at, const uint8_t *down, uint8_t *out,
                           uint32_t *histogram)
{
    struct column left = sorted_column(up[0], at[0], down[0]); /* column -1 repeats column 0 */
    struct column centre = left;
    uint32_t noise = 0;
    uint32_t x = 0;

    for (; x < COLUMNS - 2u; x += 2u) {
        const struct column right = sorted_column(up[x + 1u], at[x + 1u], down[x + 1u]);
        const struct column beyond = sorted_column(up[x + 2u], at[x + 2u], down[x + 2u]);
        noise += emit_pair(left, centre, right, beyond, &at[x], &out[x], histogram);
        left = right;
        centre = beyond;
    }
    /* the last pair: column COLUMNS repeats column COLUMNS - 1 */
    const struct column right = sorted_column(up[x + 1u], at[x + 1u], down[x + 1u]);
    return noise + emit_pair(left, centre, right, right, &at[x], &out[x], histogram);
}

/* Pass 1: the median image into `out`, its histogram into the state, and the noise removed. */
static void median_frame(struct dehazer_state *s, const uint8_t *raw, uint8_t *out)
{
    uint32_t noise = 0;
    for (uint32_t y = 0; y < ROWS; y++) {
        const uint8_t *at = raw + y * COLUMNS;
        const uint8_t *up = y == 0 ? at : at - COLUMNS;
        const uint8_t *down = y == ROWS - 1u ? at : at + COLUMNS;
        noise += median_row(up, at, down, out + y * COLUMNS, s->histogram);
    }
    s->noise_sum = noise;
}

/*
 * low and high from the histogram, which it empties for the next frame on the way. The level of
 * rank r is the number of levels v whose cumulative count (pixels at v or below) is at most r,
 * since the cumulative count never decreases: a sum of comparisons, without a branch.
 */
static void find_percentiles(struct dehazer_state *s)
{
    uint32_t cumulative = 0;
    uint32_t low = 0;
    uint32_t high = 0;

#pragma GCC unroll 16
    for (uint32_t v = 0; v < LEVELS; v++) {
        cumulative += s->histogram[v];
        s->histogram[v] = 0;
        low += cumulative <= CLIP_RANK;
        high += cumulative <= PIXELS - 1u - CLIP_RANK;
    }
    s->low = low;
    s->high = high;
}

/*
 * The stretch of [low, high] onto [0, WHITE], rounded to nearest; identity on a flat frame.
 * Below low the rounded quotient is at most 0 and above high at least WHITE (division truncates
 * towards zero), so clamping it gives the stretch's clipping without a branch per level.
 */
static void build_lut(struct dehazer_state *s)
{
    const int32_t low = (int32_t)s->low;
    const int32_t spread = (int32_t)(s->high - s->low);

    if ((uint32_t)spread < MIN_SPREAD) {
        for (uint32_t v = 0; v < LEVELS; v++) {
            s->lut[v] = (uint8_t)v;
        }
    } else {
#pragma GCC unroll 8
        for (int32_t v = 0; v < (int32_t)LEVELS; v++) {
            const int32_t level = ((v - low) * (int32_t)WHITE + spread / 2) / spread;
            const uint32_t positive = (uint32_t)(level & ~(level >> 31));
            s->lut[v] = (uint8_t)lesser(positive, WHITE);
        }
    }
    s->output_low = s->lut[s->low];
    s->output_high = s->lut[s->high];
}

/* Pass 2: every pixel through the stretch, in place. */
static void apply_lut(const struct dehazer_state *s, uint8_t *image)
{
#pragma GCC unroll 32
    for (uint32_t i = 0; i < PIXELS; i++) {
        image[i] = s->lut[image[i]];
    }
}

static int32_t dehazer_init(struct pbo_context *ctx)
{
    struct dehazer_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

static int32_t dehazer_cycle(struct pbo_context *ctx)
{
    struct dehazer_state *s = ctx->state;
    uint8_t *image = ctx->ports[PORT_IMAGE];

    median_frame(s, ctx->ports[PORT_RAW], image);
    find_percentiles(s);
    build_lut(s);
    apply_lut(s, image);
    return PBO_OK;
}

/* Switched off: the next on must not count the pause as a cycle period. */
static int32_t dehazer_off(struct pbo_context *ctx)
{
    struct dehazer_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

static int32_t dehazer_kill(struct pbo_context *ctx)
{
    (void)ctx;
    PBO_LOG("dehazer: killed");
    return PBO_OK;
}

/*
 * A cycle was stopped midway: the histogram may hold part of a frame and the output half a frame.
 * Empty the histogram and pass the raw frame through, so that what follows sees the camera's own
 * view rather than a torn one. (Word by word: the module has no memcpy to call.)
 */
static int32_t dehazer_error(struct pbo_context *ctx)
{
    struct dehazer_state *s = ctx->state;
    const uint32_t *raw = ctx->ports[PORT_RAW];
    volatile uint32_t *image = ctx->ports[PORT_IMAGE];

    find_percentiles(s);
    for (uint32_t i = 0; i < PIXELS / sizeof(uint32_t); i++) {
        image[i] = raw[i];
    }
    PBO_LOG("dehazer: error, raw frame passed through");
    return PBO_OK;
}

/* Back to off: error already emptied the histogram; restart the period measurement like off. */
static int32_t dehazer_clear(struct pbo_context *ctx)
{
    struct dehazer_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

/* The three functional values of the latest cycle, in thousandths of a grey level. */
static void report_functional(struct pbo_context *ctx)
{
    const struct dehazer_state *s = ctx->state;
    const uint32_t noise = s->noise_sum;
    /* the mean in thousandths without a 64-bit divide: noise % PIXELS * MILLI < 2^32 */
    const uint32_t noise_milli = noise / PIXELS * MILLI + noise % PIXELS * MILLI / PIXELS;
    const int32_t output_contrast = (int32_t)(s->output_high - s->output_low);

    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, PERF_OUTPUT_CONTRAST,
                        output_contrast * (int32_t)MILLI);
    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, PERF_INPUT_CONTRAST,
                        (int32_t)((s->high - s->low) * MILLI));
    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, PERF_NOISE_REMOVED, (int32_t)noise_milli);
}

/* Evaluator: observes the executor's state right after its cycle; only its own timing changes. */
static int32_t dehazer_evaluate(struct pbo_context *ctx)
{
    struct dehazer_state *s = ctx->state;
    const int32_t power = pbo_measure_power(&s->timing, IDLE_POWER_MILLI_MW, ENERGY_PER_FRAME_NJ);

    report_functional(ctx);
    pbo_sys_perf_report(ctx, PBO_PERF_NON_FUNCTIONAL, PBO_POWER_INDEX, power);
    return PBO_OK;
}

/* Estimator: the cycle on its own context and ports, then the functional values only (as the
 * paper's estimator: only configurations known to be feasible are estimated). */
static int32_t dehazer_estimate(struct pbo_context *ctx)
{
    const int32_t status = dehazer_cycle(ctx);
    if (status != PBO_OK) {
        return status;
    }
    report_functional(ctx);
    return PBO_OK;
}

static const struct pbo_descriptor dehazer_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "Dehazer",
    .state_size = sizeof(struct dehazer_state),
    .ports = {
        [PORT_RAW] = {"raw", PBO_PORT_IN, PBO_FRAME, sizeof(uint8_t), ROWS, COLUMNS},
        [PORT_IMAGE] = {"image", PBO_PORT_OUT, PBO_FRAME, sizeof(uint8_t), ROWS, COLUMNS},
    },
    .init = dehazer_init,
    .cycle = dehazer_cycle,
    .off = dehazer_off,
    .kill = dehazer_kill,
    .error = dehazer_error,
    .clear = dehazer_clear,
    .evaluate = dehazer_evaluate,
    .estimate = dehazer_estimate,
};

PBO_MODULE(dehazer_descriptor)
