/*
 * binary_messages.h - the protocol's binary mode (docs/transfer.md): a message is its type (one
 * byte 0x01-0x1F, or 0x00 and a second byte for an extended type), its fixed fields
 * little-endian, its tail, then a CRC-32 (a BlockAck: a CRC-16). hexmigrate/transfer/layout.py
 * is the model, and every refusal is its very sentence.
 *
 * A verb's fields are messages.c's table: the binary form packs the fixed fields (numbers,
 * addresses, flags) in their order and then the tail (words and free text; of several words
 * each but the last after its length in one byte). A frame decodes into the `struct message` a
 * hex-mode line decodes into, so one receiver serves both modes. Four types have no verb:
 * HEADER, DATA and SIGNATURE (a transfer's pointer words, blocks and a piece of its signature
 * area) and the
 * BlockAck; they are declared here.
 */
#ifndef NODE_BINARY_MESSAGES_H
#define NODE_BINARY_MESSAGES_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../kernel/text.h"
#include "messages.h"

enum binary_kind { BINARY_VERB, BINARY_HEADER, BINARY_DATA, BINARY_SIGNATURE, BINARY_BLOCK_ACK };

/* Where the fields of the types without a verb land in `struct message`. */
enum { BINARY_TID = 0, BINARY_INIT = 1, BINARY_ADDRESS = 1, BINARY_WORDS = 2, BINARY_PAYLOAD = 2,
       BINARY_OFFSET = 1, BINARY_AREA = 2 };

/* A decoded binary message: `message` holds a verb's fields at their index in messages.c's
 * table (a tail's bytes in text[] and text_length[], pointing into the frame), or those of a
 * type without a verb at the indices above. Its `line` is empty: a frame is no line. */
struct binary_message {
    enum binary_kind kind;
    struct message message;
};

/* Decode one message (a frame's content); false with the reason (after "bad message: "). */
bool binary_decode(const uint8_t *raw, size_t length, struct binary_message *decoded,
                   struct text *why);

/* Send an answer line a hex-mode writer made (messages.h, ` *XX` and line end included) as the
 * binary message of its verb, framed; a line that is no whole answer goes out as the refusal
 * `NAK 0 0 RETRY cannot answer: ...`, as the Python node says it cannot write an answer. */
void binary_send_line(void (*send)(const char *bytes, size_t length), const char *line,
                      size_t length);

/* The BlockAck of `programmed` bytes of transfer `tid`: its low 16 bits and the blocks. */
void binary_send_block_ack(void (*send)(const char *bytes, size_t length), uint32_t tid,
                           uint32_t programmed);

#endif
