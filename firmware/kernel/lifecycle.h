/*
 * lifecycle.h - the PBO states and the one table of legal transitions (pbort/lifecycle.py).
 *
 * ==========  ==================  ==========  ===========
 * method      from                on success  on failure
 * ==========  ==================  ==========  ===========
 * init        NOT_CREATED         OFF         NOT_CREATED
 * on          OFF                 ON          ERROR
 * cycle       ON                  ON          ERROR
 * evaluate    ON                  ON          ERROR
 * off         ON                  OFF         ERROR
 * kill        OFF, ERROR          KILLED      KILLED
 * clear       ERROR               OFF         ERROR
 * ==========  ==================  ==========  ===========
 *
 * Every lifecycle call asks the table where it may start and where it leads, so no rule lives
 * in scattered ifs.
 */
#ifndef KERNEL_LIFECYCLE_H
#define KERNEL_LIFECYCLE_H

#include <stdbool.h>
#include <stdint.h>

#include "abi.h"
#include "text.h"

enum pbo_state { STATE_NOT_CREATED, STATE_OFF, STATE_ON, STATE_ERROR, STATE_KILLED };
#define STATE_COUNT 5u

#define STATES(state) (1u << (state))
/* States in which constants may be set and the rate changed: before the PBO is switched on. */
#define CONFIGURABLE (STATES(STATE_NOT_CREATED) | STATES(STATE_OFF))
/* States in which a PBO may leave the kernel: it holds no instance. */
#define REMOVABLE (STATES(STATE_NOT_CREATED) | STATES(STATE_KILLED))

struct transition {
    enum method method;
    uint8_t sources; /* STATES(...) bits */
    enum pbo_state success;
    enum pbo_state failure;
};

/* NOT_CREATED, OFF, ON, ERROR, KILLED: the names the Python kernel's messages and PS use. */
const char *state_name(enum pbo_state state);

/* The row for `method` if it may be called in `state`; otherwise NULL, and `why` says so:
 * "PBO 'gain': cannot on from state ERROR; allowed from OFF". */
const struct transition *lifecycle_transition(const char *pbo, enum pbo_state state,
                                              enum method method, struct text *why);

/* Refuse an operation that is not a transition (configure, change the rate, remove) in
 * `state`: "PBO 'gain': cannot configure 'k' in state ON; allowed in NOT_CREATED, OFF". */
bool lifecycle_require(const char *pbo, enum pbo_state state, const char *action,
                       uint8_t allowed, struct text *why);

#endif /* KERNEL_LIFECYCLE_H */
