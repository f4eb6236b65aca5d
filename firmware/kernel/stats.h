/*
 * stats.h - what the kernel counts per PBO (pbort/stats.py): the scheduler counts timing,
 * the PBO what its methods did. ReFrESH reads these as non-functional evidence.
 */
#ifndef KERNEL_STATS_H
#define KERNEL_STATS_H

#include <stdint.h>

#include "config.h"

struct counters {
    uint32_t cycles;           /* jobs run (cycle and evaluation) */
    uint32_t missed_deadlines; /* jobs that finished after their next release */
    uint32_t overruns;         /* releases skipped because the previous job was late */
    uint32_t long_jobs;        /* own jobs that held the CPU longer than the period */
    uint32_t faults;           /* failed method calls, whatever the method */
    uint64_t busy_time_us;     /* time the PBO's jobs held the CPU */
    char last_failure[FAILURE_TEXT]; /* "cycle returned -3", "cycle faulted: ..."; "" if none */
};

#endif /* KERNEL_STATS_H */
