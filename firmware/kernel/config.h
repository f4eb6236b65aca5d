/*
 * config.h - the kernel's fixed capacities. The firmware has no heap: every table is sized
 * here, or in the capacities a build chooses (FAILURE_TEXT, MODULE_LOG_BYTES:
 * firmware/capacities/capacities.h), and the RAM they take (besides module areas in SRAM)
 * counts against the firmware's 16 KiB goal. Each number says what running out means.
 */
#ifndef KERNEL_CONFIG_H
#define KERNEL_CONFIG_H

#include "../capacities/capacities.h"

/* PBOs registered at once: one for each module the node holds (the flash directory's 5,
 * DIRECTORY_MAX_ENTRIES) and one arriving to join or replace them, which registers before the
 * directory write that commits it (loader/modules.h); node_modules.c checks the sum. More are
 * never registered, so no host meets the refusal past it (STATUS_ERR_NO_MEMORY, "the kernel
 * holds 6 PBOs, its most"). 632 bytes each. */
#define KERNEL_MAX_PBOS 6u

/* SRAM blocks at once, the most the kernel can hold: each PBO's executor area and its store
 * (pbo.h), and the one shadow run's area, inputs and outputs (estimator.h). So the table never
 * refuses a block: only the free bytes do. */
#define SRAM_MAX_BLOCKS (2u * KERNEL_MAX_PBOS + 3u)

/* Latest performance values a PBO keeps, one per (kind, index); an evaluator that reports
 * more pairs has the extra ones counted as dropped. */
#define PERFORMANCE_VALUES 4u

/* What a refused service says, before the kernel adds the module, instance and method. */
#define SERVICE_FAULT_TEXT 176u

/* Slipped jobs remembered for the slip a report gives (timekeeping.h). */
#define TIMEKEEPING_KEPT 16u

#endif /* KERNEL_CONFIG_H */
