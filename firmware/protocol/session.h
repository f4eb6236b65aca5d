/*
 * session.h - CHALLENGE, AUTH and BYE (docs/transfer.md, "Authenticated sessions") on a node
 * that trusts no key.
 *
 * The firmware checks no signature yet, so it guards nothing, and says so as the Python node
 * that trusts no key says it: a host that brings a key (`hexmigrate --key`) is answered and goes
 * on. A challenge still serves one AUTH, as there, so a host's mistakes read the same.
 */
#ifndef NODE_SESSION_H
#define NODE_SESSION_H

#include <stdint.h>

#include "../kernel/text.h"

/* Forget any challenge (a restart). */
void session_reset(void);

/* The answer line (messages.h's writers) to each request, in `reply` (answer_line). */
void session_challenge(uint32_t tid, struct text *reply);
void session_authenticate(uint32_t tid, struct text *reply);
void session_end(uint32_t tid, struct text *reply);

#endif
