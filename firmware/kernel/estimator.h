/*
 * estimator.h - a shadow run of one PBO's estimator (pbort/shadow.py for a single module).
 *
 * The estimator is the module's estimate method on an instance of its own (its own state and
 * port buffers, ROLE_ESTIMATOR), so estimating never touches the running executor, its
 * variables, its counters or its schedule, and may run for a PBO that is not running at all.
 * The run starts with the PBO's configured constants and, for each input, a snapshot of the live
 * variable it is wired to (zero when unwired); values given before the first step override
 * them. The instance sees init once (before the first step), any number of estimate calls, then
 * kill when the run is closed. A failing init or estimate stops the run there, the failure
 * kept ("estimate returned -1 at step 7"). Outputs are those of the last estimate that worked.
 * One run at a time: ReFrESH weighs candidates one after the other.
 */
#ifndef KERNEL_ESTIMATOR_H
#define KERNEL_ESTIMATOR_H

#include <stdbool.h>
#include <stdint.h>

/* Start a shadow run of PBO `name`: KERNEL_OK, or a refusal (no such PBO, no estimate method,
 * a run already open, no SRAM for the instance). */
int kernel_estimate_open(const char *name);
/* Give scalar IN, CONST or RESOURCE port "name.port" a value, before the first step. */
int kernel_estimate_give(const char *port, int64_t value);
/* Run `steps` estimates (init first, once); *done counts the steps that worked so far. */
int kernel_estimate_run(uint32_t steps, uint32_t *done);
/* A scalar port of the estimator: an output of its last good step, an input or a constant. */
int kernel_estimate_read(const char *port, int32_t *value);
/* The n-th of its latest performance values, sorted by (kind, index), as for the executor. */
bool kernel_estimate_performance_at(uint32_t n, uint8_t *kind, uint32_t *index,
                                    int32_t *value_milli);
/* "" or why it stopped: "init faulted: ..." or "estimate returned -1 at step 7". */
const char *kernel_estimate_failure(void);
/* kill (when init worked), then free the instance whatever kill did. */
void kernel_estimate_close(void);

#endif /* KERNEL_ESTIMATOR_H */
