/*
 * binary_frame.h - binary messages on the byte stream, cut and written as hexmigrate's Deframer
 * and framing.frame do it (hexmigrate/links/framing.py), and the CRC-16 that ends a BlockAck.
 *
 * A binary message travels as 0x00 COBS(message) 0x00: COBS removes every 0x00 from the message
 * (a run of at most 254 non-zero bytes is preceded by its length + 1, a code below 0xFF stands
 * for a 0x00 after its run), so a 0x00 on the wire only ever delimits a frame. The decoder takes
 * the frame a byte at a time and keeps only the decoded message, in a buffer its caller owns; a
 * message longer than that buffer is dropped whole, as a line longer than MAX_LINE is.
 */
#ifndef NODE_BINARY_FRAME_H
#define NODE_BINARY_FRAME_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* The longest binary message the node takes, as long as a line (MAX_LINE): the longest a sender
 * makes are a DATA of two blocks and a SIGNATURE of a 512-byte piece (type 00 03, tid, offset,
 * the piece, CRC-32: 526 bytes). A longer one is dropped whole, as a longer line is. */
#define BINARY_MESSAGE_MAX 1024

struct frame_decoder {
    uint8_t *buffer;
    size_t capacity;
    size_t length;    /* message bytes decoded so far */
    uint8_t run_left; /* data bytes left in the current COBS run; 0: a code byte comes next */
    bool zero_after;  /* the run's code was below 0xFF: a 0x00 follows unless the frame ends */
    bool heard, overflowed;
};

/* A frame opened (its first 0x00): decode into `buffer` of `capacity` bytes. */
void frame_decoder_start(struct frame_decoder *decoder, uint8_t *buffer, size_t capacity);

/* One byte inside the frame (never 0x00: that ends it). */
void frame_decoder_byte(struct frame_decoder *decoder, uint8_t byte);

/* Whether any byte came since the frame opened: two 0x00 in a row keep a stream in a frame,
 * which is how it resynchronises after a closing 0x00 was taken for an opening one. */
bool frame_decoder_heard(const struct frame_decoder *decoder);

/* The closing 0x00: the message's length, or 0 for garbage (COBS that does not decode, a message
 * too long for the buffer, nothing, or a first byte that no binary message starts with). */
size_t frame_decoder_end(struct frame_decoder *decoder);

#define COBS_RUN 254 /* the most non-zero bytes one code covers */

/* A frame written on the link as its message is made, byte by byte: a run's code (its length)
 * goes before its bytes, so the writer holds one run, 254 bytes, never the whole message. The
 * output is framing.cobs_encode's canonical one: full runs of 254 (code 0xFF, no 0x00 after),
 * a shorter run's code standing for the 0x00 after it; a message ending in a full run ends
 * with it. */
struct frame_writer {
    void (*send)(const char *bytes, size_t length);
    uint8_t run[COBS_RUN];
    size_t length;  /* bytes in `run` */
    bool after_full; /* nothing came since a full run was sent */
};

/* The opening 0x00. */
void frame_writer_start(struct frame_writer *writer,
                        void (*send)(const char *bytes, size_t length));
void frame_writer_put(struct frame_writer *writer, const uint8_t *bytes, size_t length);
/* The last run and the closing 0x00. */
void frame_writer_end(struct frame_writer *writer);


/* binascii.crc_hqx(data, 0xFFFF): CRC-16/CCITT, polynomial 0x1021, initial value 0xFFFF. */
uint16_t crc16_ccitt(const uint8_t *data, size_t length);

#endif
