/*
 * trap.h - module code in user mode (trap.c): the regions it may touch guarded by PMP, its
 * ecalls answered by the kernel, its faults and its watchdog ending the call as faulted.
 */
#ifndef NODE_TRAP_H
#define NODE_TRAP_H

#include <stdint.h>

/* The watchdog of one call of module code: WATCHDOG_TICKS ticks of the machine timer, each
 * WATCHDOG_TICK_US apart, 200 ms of running (the Python node's --budget of 100,000
 * instructions is 1 ms at 100 MHz; QEMU's TCG is slower and less even, and a frame of the
 * Dehazer takes milliseconds). Ticks rather than one deadline: QEMU's clock is the host's, and
 * a host that stops QEMU's thread for a while (a loaded machine) then delivers one late tick,
 * not a whole budget at once, so no call is ended for the time it did not run. */
#define WATCHDOG_TICKS 20u
#define WATCHDOG_TICK_US 10000u
#define WATCHDOG_US (WATCHDOG_TICKS * WATCHDOG_TICK_US)

/* Guard the kernel's guest regions (mapped before) for user mode and have the kernel run
 * module code through trap.c. Once, at boot. */
void trap_init(void);

/* The vector's call (start.S) for a trap of module code; `frame` holds x0..x31. Returns to
 * resume the module (an ecall answered); otherwise the call ends and it does not return. */
void trap_from_module(uint32_t *frame);

#endif
