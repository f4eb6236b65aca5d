/*
 * receiver.h - the node's side of the transfer protocol in hex mode: one state machine, fed
 * one line at a time, answering on the link (hexmigrate/transfer/receiver.py is its model).
 *
 * BEGIN opens a transfer and reserves flash; the header's 07/08 (and 09) record lines follow;
 * data record lines are loaded in address order, go-back-N: a gap is refused with the first
 * byte the node lacks (`NAK tid received RETRY ...`), data it holds already is acknowledged as a
 * `repeat`, each programmed block as `ACK tid programmed`. END checks the CRC-32 of the image as
 * it sits in flash, COMMIT makes it the node's module (a repeated COMMIT gets the same answer:
 * the last 64 are remembered), ABORT or any fatal refusal erases what the transfer wrote. A
 * transfer silent for 60 s is dropped. PING, LS and RM answer at once.
 */
#ifndef NODE_RECEIVER_H
#define NODE_RECEIVER_H

#include <stddef.h>

#define MAX_TRANSFERS 4
#define REMEMBERED_COMMITS 64
#define TRANSFER_IDLE_US 60000000ull

/* Where answers go: whole lines, each ending in '\n'. */
void receiver_init(void (*send)(const char *bytes, size_t length));

/* One text line (its line end removed), as the link delivered it. */
void receiver_handle_line(const char *line, size_t length);

/* A binary frame arrived: this node speaks hex mode only (for now), and says so. */
void receiver_handle_binary(void);

/* Drop the transfers idle for longer than TRANSFER_IDLE_US; the main loop calls it. */
void receiver_expire(void);

#endif
