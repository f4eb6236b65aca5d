/*
 * svt.h - the state-variable table (pbort/svt.py): how PBOs exchange values without knowing
 * each other.
 *
 * Every OUT port owns a variable, its buffer in its PBO's store. An IN port is bound to at most
 * one variable, or to none and then reads its port's zero value. A connection needs the same
 * element type and element count at both ends (a vector of 6 may be read as a 2x3 frame: the
 * bytes are the same); otherwise it is refused with both ports described.
 */
#ifndef KERNEL_SVT_H
#define KERNEL_SVT_H

#include <stdint.h>

#include "pbo.h"
#include "text.h"

/* Bind input `sink_port` of `sink` to the variable of output `source_port` of `source`. */
int32_t svt_connect(struct pbo *source, uint32_t source_port, struct pbo *sink,
                    uint32_t sink_port, struct text *why);
/* Unbind an input; refused when it is not bound. */
int32_t svt_disconnect(struct pbo *sink, uint32_t sink_port, struct text *why);
/* Inputs bound to any variable of `source` become unbound (it leaves the kernel). */
void svt_forget(const struct pbo *source);
/* The guest address of what a port holds now: an output's variable, what an input reads (NULL
 * address 0 for an unbound input: its zero value), a constant's configured value. */
uint32_t svt_value(const struct pbo *pbo, uint32_t port);

/* "pbo.port" into `text`. */
void svt_add_port(struct text *text, const struct pbo *pbo, uint32_t port);

#endif /* KERNEL_SVT_H */
