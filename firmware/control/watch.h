/*
 * watch.h - WATCH: what a watched node pushes by itself (hexmigrate/transfer/subscription.py).
 *
 * Every period of the kernel's clock a REPORT (leftover power, slip and missed releases since
 * the last report, each PBO's latest log line number `PBO:L`, each running PBO's latest
 * evaluator values `PBO:F0`, `PBO:N0`, the watched ports), every second a BEAT (a line about
 * the node's PBOs); both carry the clock in milliseconds and one sequence number, in the
 * mode the watch came in. The firmware has one link, so one watch.
 */
#ifndef NODE_WATCH_H
#define NODE_WATCH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../protocol/messages.h"

/* Start, change or end (period 0) the watch; the ACK or the refusal's reason in `reply`. False
 * with the reason in `why` when refused. */
bool watch_request(const struct message *request, struct text *reply, struct text *why);

/* The node's clock started again (RESET): the next report and beat count from now. */
void watch_restart(void);

/* Send what is due now (none, a report, a beat or both). The main loop calls it. */
void watch_push(void (*send)(const char *bytes, size_t length));

/* When the next push is due (the kernel's clock): false when nothing is watched. */
bool watch_next(uint64_t *when_us);

#endif
