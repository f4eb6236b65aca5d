/*
 * kernel_internal.h - what the kernel's parts share with kernel.c: the PBO table, the clock
 * and the PBOs' logs. Not for the protocol or the board: they use kernel.h.
 */
#ifndef KERNEL_INTERNAL_H
#define KERNEL_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "config.h"
#include "kernel.h"
#include "pbo.h"
#include "power.h"
#include "text.h"
#include "timekeeping.h"

#define NO_OWNER 0xFFFFFFFFu

/* The kernel's tables, one instance (kernel.c); the parts of kernel.h's API share them. */
#define MESSAGE_TEXT 240u /* kernel_message(): a refusal, cut there */

struct kernel_state {
    struct kernel_config config;
    uint32_t serials; /* here, not after the flags: fills the gap before the 8-aligned PBOs */
    struct pbo pbos[KERNEL_MAX_PBOS];
    uint32_t draws_uw[KERNEL_MAX_PBOS]; /* each ON PBO's accepted power draw */
    bool draw_refused[KERNEL_MAX_PBOS]; /* its latest draw report was negative: noted once */
    uint64_t epoch_us; /* the board's time when the kernel's clock (re)started */
    struct timekeeping keeping;
    struct power power;
    char message[MESSAGE_TEXT];
};

extern struct kernel_state kernel;


/* kernel_message() emptied, to write a refusal into. */
struct text kernel_message_text(void);
/* The node's own log (kernel_config.note), when the board gave one. */
void kernel_note(const char *text, uint32_t length);
/* A PBO in the table, not a module waiting for admission. */
bool kernel_admitted(const struct pbo *pbo);
/* The admitted PBO `name`, or NULL (nothing said). */
struct pbo *kernel_named(const char *name);
/* The admitted PBO of rank `index` in registration order, or NULL. */
struct pbo *kernel_at_rank(uint32_t index);
/* pbo_control's result as kernel.h's: 0, KERNEL_ERR_FAILED or KERNEL_ERR_REFUSED. */
int kernel_result_of(int32_t control);
/* A rate a host may ask for; else false with the refusal said. */
bool kernel_valid_rate(const char *name, uint32_t millihertz);
/* Energy drawn until now at the accepted draws, then each ON PBO's latest draw accepted. */
void kernel_account_power(void); /* a line logged by an init subroutine: the node's own log */

/* The kernel's time: the board's clock since the kernel's clock (re)started. */
uint64_t kernel_now_us(void);

/* A line a module logged: kept in its PBO's log, or the node's own log for NO_OWNER. */
void kernel_log_line(uint32_t owner, const char *text, uint32_t length);

/* Whether REGISTER must refuse `name` (see registrar.h for `replacing`). */
bool kernel_name_taken(const char *name, bool replacing);

/* Say why a kernel.h call is refused, in kernel_message() (text_format's conversions); returns
 * `result`. */
int kernel_refuse(int result, const char *format, ...);
/* The admitted PBO `name`, or NULL with "unknown PBO ..." said. */
struct pbo *kernel_find(const char *name);
/* The PBO and port index of "pbo.port", or NULL with "unknown port ..." said ("unknown PBO ..."
 * when the part before the dot names none, however long). */
struct pbo *kernel_find_port(const char *name, uint32_t *port);

/* Rank the admitted PBOs for the ties of a release by their wiring as it is now (`flow`,
 * flow_order.c): after every change of a binding, an admission or a removal. */
void kernel_reorder(void);

/* The PBO in slot `slot` (admitted or pending). */
struct pbo *kernel_slot(uint32_t slot);
uint32_t kernel_slot_of(const struct pbo *pbo);

/* The shadow run (estimator.h) as the kernel restarts, or as the PBO it runs leaves. */
void estimator_reset(void);
void estimator_forget(const struct pbo *pbo);

#endif /* KERNEL_INTERNAL_H */
