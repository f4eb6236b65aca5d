/*
 * control.h - the seam for node control requests (PS, START, STOP, SET, ... docs/transfer.md).
 *
 * The receiver decodes every control request and hands it here. The kernel (firmware/kernel)
 * answers those it can by writing one whole reply line (ACK, PBOS, VALUES, ... with its ` *XX`
 * and line end, messages.h's writers) into `reply` and returning true. Until it does, the weak
 * default returns false and the receiver refuses the request as the Python node does when it has
 * no control target: `NAK TID 0 FATAL VERB refused: this node takes no control requests`.
 */
#ifndef NODE_CONTROL_H
#define NODE_CONTROL_H

#include <stdbool.h>

#include "../kernel/text.h"
#include "../protocol/messages.h"

bool node_control(const struct message *request, struct text *reply);

#endif
