/*
 * harness.h - the two hooks of the host harness's loop (receiver_harness.c), which does nothing
 * in them; the node harness (node_harness.c) runs the kernel there.
 */
#ifndef HOST_HARNESS_H
#define HOST_HARNESS_H

#include <stddef.h>

/* Before the node boots (each boot: a restart directive boots again). */
void harness_start(void);

/* After each message and directive: what the board's loop does between bytes. */
void harness_step(void (*send)(const char *bytes, size_t length));

#endif /* HOST_HARNESS_H */
