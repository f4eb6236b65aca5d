/*
 * module_log.h - each PBO's recent log lines: what its module wrote through the LOG service
 * (pbort/module_log.py).
 *
 * A module says why it refuses to start ("gain: k is not configured"); a node far from its
 * operator keeps those lines where a host can ask for them (LOGS), numbered per PBO from 1, so
 * that a refusal can quote what the module said during the failed call and a follower asks
 * only for what is new. The Python kernel keeps 64 lines per PBO; the firmware keeps the newest
 * lines of all PBOs together in one ring of MODULE_LOG_BYTES, the oldest dropped first, so the
 * RAM is fixed whatever the modules log. A line is at most ABI_LOG_LIMIT (256) bytes, the
 * module's bytes as they came: a host shows them escaped.
 */
#ifndef KERNEL_MODULE_LOG_H
#define KERNEL_MODULE_LOG_H

#include <stdint.h>

struct log_line {
    uint32_t number;  /* in its PBO's log, from 1 */
    uint64_t time_us; /* the kernel's time when it was logged */
    uint32_t length;
    const char *text; /* valid only during the visit */
};

/* Called for each line a query finds, oldest first; `context` is the caller's. */
typedef void (*log_visitor)(const struct log_line *line, void *context);

void module_log_reset(void);
/* Keep `length` bytes of `text` (cut at 256) as line `number` of the PBO with serial `owner`. */
void module_log_append(uint32_t owner, uint32_t number, uint64_t time_us, const char *text,
                       uint32_t length);
/* Visit the kept lines of `owner` numbered above `since`, oldest first. */
void module_log_since(uint32_t owner, uint32_t since, log_visitor visit, void *context);

#endif /* KERNEL_MODULE_LOG_H */
