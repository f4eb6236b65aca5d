/*
 * control_text.h - the free text of control answers, written as hexmigrate/transfer/control.py
 * writes it on the Python node: numbers as Python prints them, PS rows, a PBO's description
 * and its log lines as JSON (json.dumps with its default separators and ensure_ascii).
 */
#ifndef NODE_CONTROL_TEXT_H
#define NODE_CONTROL_TEXT_H

#include <stdbool.h>
#include <stdint.h>

#include "../kernel/text.h"

/* Characters of log lines or description one answer carries at most (control.py's
 * MAX_LOG_TEXT): a hex-mode line holds 1,024. */
#define CONTROL_TEXT_MAX 800

/* A rate as Python's f"{hertz:g}" prints millihertz / 1000: "100", "12.5", "0.01". */
void control_add_hertz(struct text *text, uint32_t millihertz);
/* Thousandths as a Python float's repr of value / 1000 for 3 decimals: "99.999", "100.0". */
void control_add_milli(struct text *text, int64_t milli);
void control_add_signed(struct text *text, int64_t value);

/* PS: every PBO's NAME:STATE:RATE:IN,..:OUT,..:CONST,.. word. */
void control_pbo_rows(struct text *text);
/* DESCRIBE: PBO `name`'s description (control.py's description_text); false when the kernel
 * does not know it (kernel_message() says why). */
bool control_description(struct text *text, const char *name);
/* LOGS: PBO `name`'s latest line number; false when the kernel does not know it. */
bool control_log_latest(const char *name, uint32_t *latest);
/* LOGS: PBO `name`'s lines after `since` as log_text writes them. */
void control_log_lines(struct text *text, const char *name, uint32_t since);
/* The heartbeat's line: "node: 2 PBOs: 1 OFF, 1 ON". */
void control_state_line(struct text *text);

#endif
