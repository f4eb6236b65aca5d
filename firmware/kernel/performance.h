/*
 * performance.h - the latest value of each (kind, index) an evaluator or an estimator reported
 * (pbort/performance_buffer.py's `latest`). A node answers a host with the latest values only,
 * so the firmware keeps those and not the Python buffer's history.
 */
#ifndef KERNEL_PERFORMANCE_H
#define KERNEL_PERFORMANCE_H

#include <stdbool.h>
#include <stdint.h>

#include "config.h"

/* No time of the report: nothing a node answers says when a value came. */
struct performance_value {
    uint32_t index;      /* which value of its kind */
    int32_t value_milli; /* thousandths of its unit (a power of 1.25 mW is 1250) */
};

struct performance {
    struct performance_value values[PERFORMANCE_VALUES];
    uint32_t dropped; /* reports of a new (kind, index) once all PERFORMANCE_VALUES were used */
    uint8_t count;    /* values in use, in the order their (kind, index) first came */
    /* Bit i: values[i] is PERFORMANCE_NON_FUNCTIONAL, else PERFORMANCE_FUNCTIONAL, the ABI's
     * only kinds (PERF_REPORT refuses others): a bit each instead of a padded byte. */
    uint8_t non_functional;
};

void performance_clear(struct performance *performance);
/* `kind` is an enum performance_kind. */
void performance_file(struct performance *performance, uint8_t kind, uint32_t index,
                      int32_t value_milli);
/* The latest value of (kind, index), or NULL when none was filed. */
const struct performance_value *performance_latest(const struct performance *performance,
                                                   uint8_t kind, uint32_t index);

/* The n-th value in (kind, index) order, the order a report lists them in; false past the
 * last. */
bool performance_ranked(const struct performance *performance, uint32_t n, uint8_t *kind,
                        uint32_t *index, int32_t *value_milli);

#endif /* KERNEL_PERFORMANCE_H */
