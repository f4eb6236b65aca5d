/*
 * Pursuit - a pure-pursuit controller: steer onto the arc through a point of the line one
 * lookahead distance ahead.
 *
 * From the offset e (mm, positive to the left of travel) and the heading error psi (mrad), the
 * look-ahead point in the rover's frame lies y = -e cos(psi) - L sin(psi) to its left (small-angle
 * series for sin and cos, psi clamped to +-1 rad); the arc through it has curvature
 * 2 y / (L^2 + e^2), and the turn rate is the speed times that curvature. All in 32-bit integers:
 * millimetres, milliradians, mrad/s.
 *
 * Ports: offset, heading (inputs), turn (output, mrad/s), lookahead (mm) and speed (mm/s)
 * (constants, both > 0).
 * Evaluator: functional 0 = |offset| in thousandths of a metre (the task's metric "offset");
 * non-functional 0 = power (thousandths of a mW), 1 = CPU load (percent, in thousandths).
 * Estimator: the cycle on its own ports, then the same functional report.
 */
#include "pbo_module.h"

enum { PORT_OFFSET, PORT_HEADING, PORT_TURN, PORT_LOOKAHEAD, PORT_SPEED, PORT_COUNT };

#define IDLE_POWER_MILLI_MW 400u
#define ENERGY_PER_CYCLE_NJ 120u /* a few products and one division */
#define CPU_LOAD_MILLI 15000     /* 15 % of a node: its share in the module database */
#define PSI_LIMIT 1000           /* mrad: where the series stay close */
#define SIDE_LIMIT 1000          /* mm: the look-ahead point's lateral clamp */

struct pursuit_state {
    struct pbo_timing timing;
};

static int32_t port(const struct pbo_context *ctx, int index)
{
    return *(const int32_t *)ctx->ports[index];
}

static int32_t clamp(int32_t value, int32_t limit)
{
    return value > limit ? limit : (value < -limit ? -limit : value);
}

static int32_t pursuit_init(struct pbo_context *ctx)
{
    struct pursuit_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

static int32_t pursuit_on(struct pbo_context *ctx)
{
    if (port(ctx, PORT_LOOKAHEAD) <= 0 || port(ctx, PORT_SPEED) <= 0) {
        PBO_LOG("Pursuit: expected lookahead > 0 and speed > 0");
        return PBO_ERR_INVALID;
    }
    return PBO_OK;
}

static int32_t pursuit_cycle(struct pbo_context *ctx)
{
    const int32_t e = clamp(port(ctx, PORT_OFFSET), 2000);
    const int32_t psi = clamp(port(ctx, PORT_HEADING), PSI_LIMIT);
    const int32_t lookahead = port(ctx, PORT_LOOKAHEAD);
    const int32_t speed = port(ctx, PORT_SPEED);
    /* sin and cos in thousandths: psi - psi^3 / 6, 1 - psi^2 / 2 (psi in mrad) */
    const int32_t psi2 = psi * psi / 1000;
    const int32_t sine = psi - psi * psi2 / 6000;
    const int32_t cosine = 1000 - psi2 / 2;
    const int32_t side = clamp(-(e * cosine) / 1000 - (lookahead * sine) / 1000, SIDE_LIMIT);
    /* turn = speed * 2 * side / (L^2 + e^2) rad/s, in mrad/s; L^2 in units of 100 mm^2 */
    const int32_t reach = (lookahead * lookahead + e * e) / 100;
    *(int32_t *)ctx->ports[PORT_TURN] = (speed * 20 * side) / (reach > 0 ? reach : 1);
    return PBO_OK;
}

static int32_t pursuit_off(struct pbo_context *ctx)
{
    struct pursuit_state *s = ctx->state;
    pbo_timing_reset(&s->timing);
    return PBO_OK;
}

static int32_t offset_milli(const struct pbo_context *ctx)
{
    const int32_t e = port(ctx, PORT_OFFSET);
    return e < 0 ? -e : e;
}

static int32_t pursuit_evaluate(struct pbo_context *ctx)
{
    struct pursuit_state *s = ctx->state;
    const int32_t power = pbo_measure_power(&s->timing, IDLE_POWER_MILLI_MW, ENERGY_PER_CYCLE_NJ);

    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, 0, offset_milli(ctx));
    pbo_sys_perf_report(ctx, PBO_PERF_NON_FUNCTIONAL, PBO_POWER_INDEX, power);
    pbo_sys_perf_report(ctx, PBO_PERF_NON_FUNCTIONAL, 1, CPU_LOAD_MILLI);
    return PBO_OK;
}

static int32_t pursuit_estimate(struct pbo_context *ctx)
{
    pursuit_cycle(ctx);
    pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, 0, offset_milli(ctx));
    return PBO_OK;
}

static const struct pbo_descriptor pursuit_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "Pursuit",
    .state_size = sizeof(struct pursuit_state),
    .ports = {
        [PORT_OFFSET] = {"offset", PBO_PORT_IN, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_HEADING] = {"heading", PBO_PORT_IN, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_TURN] = {"turn", PBO_PORT_OUT, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_LOOKAHEAD] = {"lookahead", PBO_PORT_CONST, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_SPEED] = {"speed", PBO_PORT_CONST, PBO_SCALAR, sizeof(int32_t), 1, 1},
    },
    .init = pursuit_init,
    .on = pursuit_on,
    .cycle = pursuit_cycle,
    .off = pursuit_off,
    .evaluate = pursuit_evaluate,
    .estimate = pursuit_estimate,
};

PBO_MODULE(pursuit_descriptor)
