/*
 * line_reader.h - whole messages out of the UART's byte stream, as hexmigrate's Deframer cuts
 * them (hexmigrate/links/framing.py).
 *
 * A text message is a line ending in '\n' (a '\r' before it is dropped); a binary message is
 * 0x00 COBS 0x00. The reader never stops on what it reads: a line longer than MAX_LINE is
 * dropped whole, a 0x00 in a line drops what came before it, and the stream resynchronises at
 * the next delimiter. It keeps no binary frame (the node answers binary with a refusal for
 * now), only notes that one arrived.
 */
#ifndef NODE_LINE_READER_H
#define NODE_LINE_READER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define MAX_LINE 1024

enum line_event { LINE_NONE, LINE_TEXT, LINE_BINARY };

struct line_reader {
    char line[MAX_LINE + 2];
    size_t length;
    bool overflowed, in_frame, frame_has_bytes, complete;
    uint32_t dropped; /* lines and frames given up as garbage */
};

void line_reader_init(struct line_reader *reader);

/* Take one byte; LINE_TEXT when it completed a line (reader->line, reader->length, no line
 * end), LINE_BINARY when it closed a binary frame. */
enum line_event line_reader_feed(struct line_reader *reader, uint8_t byte);

#endif
