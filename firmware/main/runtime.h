/*
 * runtime.h - the kernel on this firmware: its memory mapped, module code guarded in user
 * mode, due jobs run from the main loop, and each module that arrives started (or left off)
 * as `firmware-sim listen` starts it (firmware_sim/serving/pbo_setup.py).
 */
#ifndef NODE_RUNTIME_H
#define NODE_RUNTIME_H

#include <stdbool.h>

#include "../kernel/text.h"

/* Modules a host may hold off at once (kernel_control.py's MAX_HELD). */
#define RUNTIME_MAX_HELD 16

/* Map the board's flash and module memory for the kernel, start it, guard module code. Once,
 * before the loader boots the modules in flash (their init runs then). */
void runtime_init(void);

/* Start each module that arrived since (unless held or the board says not to), then run the
 * due job that goes first, if any. The main loop calls it between lines. */
void runtime_step(void);

/* HOLD: leave module `name` off when it is installed next. The ACK's text, or false with the
 * refusal's reason, in `said`. */
bool runtime_hold(const char *name, struct text *said);

/* RESET: no module held any more. */
void runtime_forget_holds(void);

#endif
