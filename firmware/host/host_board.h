/*
 * host_board.h - what the host harness controls of its board stub (host_board.c): the clock,
 * power cuts, and the flash file.
 */
#ifndef HOST_BOARD_H
#define HOST_BOARD_H

#include <stdint.h>

/* Move the clock on (idle transfers expire). */
void host_board_advance(uint64_t microseconds);

/* The power fails during the `count`-th next flash erase or program (1: the next one): that
 * operation does half its work, and every later one does nothing and fails, until
 * host_board_restore_power. */
void host_board_cut_power_after(uint32_t count);
void host_board_restore_power(void);
/* Whether a planned cut is still to come (the operations so far did not reach it). */
int host_board_cut_pending(void);

/* Keep the flash in `path` (loaded when it exists, written back by host_board_save). */
void host_board_load(const char *path);
void host_board_save(const char *path);

#endif
