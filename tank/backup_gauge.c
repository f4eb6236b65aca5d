/*
 * backup_gauge - the tank's backup level gauge as a guest module, for a robot whose node runs no
 * Python natives (the C firmware on a board or on QEMU: tank_qemu.toml).
 *
 * Ports: mm (output, the level in millimetres), level (constant: the level it reads).
 * Evaluator: non-functional value 0 = power in thousandths of a mW (4 mW, as BackupGauge's).
 * Estimator: the same reading on its own ports.
 */
#include "pbo_module.h"

enum { PORT_MM, PORT_LEVEL, PORT_COUNT };

#define POWER_MILLI_MW 4000 /* 4 mW: the backup gauge draws more than robot a's */

static int32_t gauge_cycle(struct pbo_context *ctx)
{
    *(int32_t *)ctx->ports[PORT_MM] = *(const int32_t *)ctx->ports[PORT_LEVEL];
    return PBO_OK;
}

static int32_t gauge_evaluate(struct pbo_context *ctx)
{
    pbo_sys_perf_report(ctx, PBO_PERF_NON_FUNCTIONAL, PBO_POWER_INDEX, POWER_MILLI_MW);
    return PBO_OK;
}

static const struct pbo_descriptor gauge_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "backup_gauge",
    .state_size = 0,
    .ports = {
        [PORT_MM] = {"mm", PBO_PORT_OUT, PBO_SCALAR, sizeof(int32_t), 1, 1},
        [PORT_LEVEL] = {"level", PBO_PORT_CONST, PBO_SCALAR, sizeof(int32_t), 1, 1},
    },
    .cycle = gauge_cycle,
    .evaluate = gauge_evaluate,
    .estimate = gauge_cycle,
};

PBO_MODULE(gauge_descriptor)
