/*
 * line_reader.h - whole messages out of the UART's byte stream, as hexmigrate's Deframer cuts
 * them (hexmigrate/links/framing.py).
 *
 * A text message is a line ending in '\n' (a '\r' before it is dropped); a binary message is
 * 0x00 COBS 0x00. The reader never stops on what it reads: a line longer than MAX_LINE is
 * dropped whole, a 0x00 in a line drops what came before it, and the stream resynchronises at
 * the next delimiter. A binary frame is decoded as it comes (binary_frame.h) into the buffer
 * a line uses: a line and a frame never fill it at once.
 */
#ifndef NODE_LINE_READER_H
#define NODE_LINE_READER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "binary_frame.h"

#define MAX_LINE 1024

enum line_event { LINE_NONE, LINE_TEXT, LINE_BINARY };

struct line_reader {
    union { /* one buffer for a line or a frame */
        char line[MAX_LINE + 2];
        uint8_t frame[BINARY_MESSAGE_MAX];
    };
    size_t length; /* of the line, or of the binary message in `frame` */
    bool overflowed, in_frame, complete;
    struct frame_decoder decoder;
    uint32_t dropped; /* lines and frames given up as garbage */
};

void line_reader_init(struct line_reader *reader);

/* Take one byte; LINE_TEXT when it completed a line (reader->line, reader->length, no line
 * end), LINE_BINARY when it closed a binary frame (its message in reader->frame,
 * reader->length). Either is valid until the next byte. */
enum line_event line_reader_feed(struct line_reader *reader, uint8_t byte);

#endif
