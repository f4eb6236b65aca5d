/*
 * config.h - the kernel's fixed capacities. The firmware has no heap: every table is sized
 * here, and the RAM they take (besides module areas in SRAM) counts against the firmware's
 * 16 KiB goal. Each number says what running out means.
 */
#ifndef KERNEL_CONFIG_H
#define KERNEL_CONFIG_H

/* PBOs registered at once; REGISTER refuses a module past it with STATUS_ERR_NO_MEMORY. */
#define KERNEL_MAX_PBOS 8u

/* SRAM blocks at once, the most the kernel can hold: each PBO's executor area and its store
 * (pbo.h), and the one shadow run's area, inputs and outputs (estimator.h). So the table never
 * refuses a block: only the free bytes do. */
#define SRAM_MAX_BLOCKS (2u * KERNEL_MAX_PBOS + 3u)

/* Latest performance values a PBO keeps, one per (kind, index); an evaluator that reports
 * more pairs has the extra ones counted as dropped. */
#define PERFORMANCE_VALUES 4u

/* Bytes of module log lines kept, for all PBOs together (module_log.h). */
#define MODULE_LOG_BYTES 1536u

/* Characters of a PBO's last failure kept (Stats.last_failure), the fault text included. */
#define FAILURE_TEXT 256u

/* What a refused service says, before the kernel adds the module, instance and method. */
#define SERVICE_FAULT_TEXT 176u

/* Slipped jobs remembered for the slip a report gives (timekeeping.h). */
#define TIMEKEEPING_KEPT 16u

#endif /* KERNEL_CONFIG_H */
