/*
 * kernel.h - the PBO/RT kernel of the node firmware: what the board and the transfer
 * protocol's control requests call (docs/pbort.md describes the kernel this one matches).
 *
 * The board maps the guest memory regions (guest_memory.h), starts the kernel with its clock,
 * runs due jobs from its main loop, and passes every ecall of module code to kernel_service.
 * The loader registers each module it wrote to flash; the protocol's control requests (PS,
 * START, STOP, CLEAR, SET, RATE, CONNECT, DISCONNECT, READ, LOGS, WATCH/REPORT, RESET) map onto
 * the calls below one to one, as firmware_sim/serving/kernel_control.py does on the Python node.
 *
 * PBOs and ports are named by NUL-terminated strings, "gain" and "gain.y", as requests carry
 * them. A call that cannot be done returns a negative `enum kernel_result` and leaves a sentence
 * in kernel_message() naming the PBO or port and saying what was expected: the text to send
 * back in a refusal. The kernel runs on one CPU and is not reentrant: call it from the main loop
 * (and kernel_service from the trap handler of module code it called), never from an interrupt.
 */
#ifndef KERNEL_KERNEL_H
#define KERNEL_KERNEL_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator.h"
#include "module_log.h"

/* --- Starting ------------------------------------------------------------------------- */

struct kernel_config {
    uint64_t (*now_us)(void); /* the board's monotonic clock in µs */
    /* Wait until the clock reads `when_us` (kernel_run only); NULL: kernel_run returns when no
     * job is due instead of waiting. */
    void (*wait_until_us)(uint64_t when_us);
    /* The node's own log: init subroutines' LOG lines and what the kernel notes; may be NULL. */
    void (*note)(const char *text, uint32_t length);
    uint32_t energy_mj;    /* battery capacity: 3600000 for the Python node's 3600 J */
    uint32_t base_draw_uw; /* the node's own draw: 50000 for the Python node's 50 mW */
};

/* Start (or restart) the kernel: no PBOs, SRAM all free. Map the regions first. */
void kernel_init(const struct kernel_config *config);

enum kernel_result {
    KERNEL_OK = 0,
    KERNEL_ERR_UNKNOWN = -10,   /* no PBO or port of that name */
    KERNEL_ERR_REFUSED = -11,   /* not in this state, wrong direction, wiring, value, room */
    KERNEL_ERR_FAILED = -12,    /* the module's method failed; the PBO changed state */
};

/* Why the last call that returned an error did so. */
const char *kernel_message(void);

/* --- Modules (the loader) ------------------------------------------------------------- */

/*
 * Run the init subroutine at `init` of the image at `base` (`size` bytes, in flash, pointers
 * fixed) and take the module it registers as *slot, pending: not a PBO yet. Returns the
 * REGISTER status (STATUS_OK 0, or STATUS_ERR_INVALID, _ABI, _NO_MEMORY, _EXISTS as
 * docs/module-abi.md lists them), STATUS_ERR_INVALID also when the subroutine faulted or never
 * registered; kernel_message() says why. `replacing`: a module of a registered PBO's name is
 * accepted, to replace it at kernel_admit (a host sends a new version); false at boot.
 */
int32_t kernel_register_module(uint32_t base, uint32_t size, uint32_t init, bool replacing,
                               uint32_t *slot);
/* The pending module becomes a PBO, NOT_CREATED, at `millihertz`; a PBO of its name is
 * switched off, killed and removed first, whatever its methods answer. Call it after the
 * flash directory lists the new module (the commit point). */
int kernel_admit(uint32_t slot, uint32_t millihertz);
/* Forget a pending module (its image is being erased). */
void kernel_discard(uint32_t slot);
/* The module's name, pending or admitted, for the loader's directory entry. */
const char *kernel_module_name(uint32_t slot);
/* Take PBO `name` off the kernel (RM): off, kill, remove, whatever its methods answer. */
int kernel_remove(const char *name);

/* --- Control requests ------------------------------------------------------------------ */

int kernel_start(const char *name); /* START: init when NOT_CREATED, then on */
int kernel_stop(const char *name);  /* STOP: off */
int kernel_clear(const char *name); /* CLEAR: ERROR -> OFF */
/* The lifecycle calls themselves, as pbort's Kernel.spawn/on/off/kill. */
int kernel_spawn(const char *name);
int kernel_on(const char *name);
int kernel_off(const char *name);
int kernel_kill(const char *name);

/* SET PBO.port=VALUE: a scalar CONST port, `value` exactly in its element type (the protocol
 * parses the number and refuses a fraction: a Q16.16 constant travels as its raw integer). */
int kernel_set_constant(const char *port, int64_t value);
/* RATE: from the PBO's next start; 10 mHz to 100 kHz (RATE_MIN, RATE_MAX of the Python node). */
int kernel_set_rate(const char *name, uint32_t millihertz);
int kernel_connect(const char *source, const char *sink);
/* DISCONNECT: refused when `sink` is not wired to `source`. */
int kernel_disconnect(const char *source, const char *sink);
/* READ: a scalar port's value (an output's variable, what an input reads, a constant). */
int kernel_read(const char *port, int32_t *value);
/* RESET: every running PBO off, every wire undone, the clock from 0; how many of each. */
void kernel_reset(uint32_t *switched_off, uint32_t *wires);

/* --- Observation (PS, LOGS, DESCRIBE, WATCH) --------------------------------------------- */

#define KERNEL_MILLIHERTZ_MIN 10u
#define KERNEL_MILLIHERTZ_MAX 100000000u

struct kernel_pbo {
    const char *name;
    const char *state;     /* NOT_CREATED, OFF, ON, ERROR, KILLED */
    uint32_t millihertz;   /* its rate */
    uint32_t port_count;
    const char *port_names[8];
    uint8_t port_directions[8]; /* 0 IN, 1 OUT, 2 CONST, 3 RESOURCE */
    uint8_t port_kinds[8];      /* 0 scalar, 1 vector, 2 frame */
    uint16_t element_sizes[8];  /* 1 (uint8), 2 (int16), 4 (int32) */
};

struct kernel_stats {
    uint32_t cycles, missed_deadlines, overruns, long_jobs, faults;
    uint64_t busy_time_us;
    const char *last_failure; /* "" when none */
    uint32_t logged;          /* the number of its module's latest log line (0: none) */
};

/* The PBOs in registration order: index 0 .. kernel_pbo_count() - 1. */
uint32_t kernel_pbo_count(void);
bool kernel_pbo_at(uint32_t index, struct kernel_pbo *pbo);
int kernel_stats(const char *name, struct kernel_stats *stats);
/* A wire into or out of PBO `name` (or any PBO, for NULL): the n-th, from 0; false past the
 * last. `source` and `sink` get "PBO.port" (buffers of at least 32 bytes). */
bool kernel_wire_at(const char *name, uint32_t n, char *source, char *sink);
/* LOGS: visit PBO `name`'s kept lines numbered above `since`, oldest first. */
int kernel_log(const char *name, uint32_t since, log_visitor visit, void *context);

/* WATCH/REPORT: what a node says of itself and of each running PBO. */
struct kernel_status {
    uint32_t leftover_milli; /* energy left, thousandths of the 0-100 scale */
    uint64_t slip_us;        /* the largest slip of the jobs since `since` */
    uint32_t missed;         /* releases missed on slips since the clock started */
};
void kernel_status(uint64_t since_us, struct kernel_status *status);
/* The n-th latest performance value of PBO `index` (registration order) while it is ON:
 * kind (0 functional "F", 1 non-functional "N"), index and value in thousandths. */
bool kernel_performance_at(uint32_t index, uint32_t n, uint8_t *kind, uint32_t *value_index,
                           int32_t *value_milli);

/* --- Running ---------------------------------------------------------------------------- */

uint64_t kernel_time_us(void); /* the kernel's clock: µs since it (re)started */
/* Run the due job that goes first, if any; true when one ran. The main loop calls it until it
 * returns false, then waits for the next release or its link. */
bool kernel_run_once(void);
/* When the next job is due (kernel time); false when none is released. */
bool kernel_next_release(uint64_t *when_us);
/* Run jobs released before `until_us` (kernel time), at most `cycles` of them, waiting on the
 * clock between them; returns the jobs run (pbort's Kernel.run). */
uint32_t kernel_run(uint64_t until_us, uint32_t cycles);

/* --- The board's trap handler ------------------------------------------------------------ */

/*
 * An ecall from module code: a7 = `number`, a0..a3; the result goes to a0. When
 * kernel_service_faulted() is then true, the service refused its arguments: the handler ends
 * the call with module_call_abort() (module_call.h) instead of returning to the module.
 */
int32_t kernel_service(uint32_t number, uint32_t a0, uint32_t a1, uint32_t a2, uint32_t a3);
bool kernel_service_faulted(void);
/* A fault the board caught in module code (memory fault, illegal instruction, watchdog): the
 * text the PBO's last failure quotes. Then module_call_abort(). */
void kernel_fault(const char *text);

#endif /* KERNEL_KERNEL_H */
