/*
 * receiver.h - the node's side of the transfer protocol in both modes: one state machine, fed
 * one line or one binary message at a time, answering on the link in the mode the message came
 * in (hexmigrate/transfer/receiver.py is its model).
 *
 * BEGIN opens a transfer and reserves flash; the header follows (hex mode: its 07/08 and 09
 * record lines; binary mode: SIGNATURE and HEADER); the data (record lines, or DATA messages)
 * is loaded in address order, go-back-N: a gap is refused with the first byte the node lacks
 * (`NAK tid received RETRY ...`), data it holds already is acknowledged as a `repeat`, each
 * programmed block as `ACK tid programmed` (binary mode: a BlockAck). END checks the CRC-32 of
 * the image as it sits in flash, COMMIT makes it the node's module (a repeated COMMIT gets the
 * same answer: the last REMEMBERED_COMMITS are remembered), ABORT or any fatal refusal erases
 * what the transfer wrote. A transfer silent for 60 s is dropped. PING, LS and RM answer at
 * once. At most MAX_TRANSFERS are open at once (firmware/capacities/capacities.h).
 */
#ifndef NODE_RECEIVER_H
#define NODE_RECEIVER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../capacities/capacities.h" /* MAX_TRANSFERS, REMEMBERED_COMMITS */

#define TRANSFER_IDLE_US 60000000ull

/* Where answers go: whole lines, each ending in '\n'. */
void receiver_init(void (*send)(const char *bytes, size_t length));

/* One text line (its line end removed), as the link delivered it. */
void receiver_handle_line(const char *line, size_t length);

/* One binary message (a frame's content), answered in binary mode: the same state machine,
 * with HEADER, SIGNATURE and DATA for the header's and the data's record lines. */
void receiver_handle_binary(const uint8_t *message, size_t length);

/* Drop the transfers idle for longer than TRANSFER_IDLE_US; the main loop calls it. */
void receiver_expire(void);

/* Whether the message being answered came in binary mode: a watch pushes in the mode it came
 * in (watch.c). */
bool receiver_answering_binary(void);

#endif
