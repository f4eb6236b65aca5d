/*
 * line_reader.c - the stream deframer (line_reader.h).
 */
#include "line_reader.h"

void line_reader_init(struct line_reader *reader)
{
    reader->length = 0;
    reader->overflowed = reader->in_frame = reader->complete = false;
    reader->dropped = 0;
}

static void reset(struct line_reader *reader)
{
    reader->length = 0;
    reader->overflowed = false;
}

static enum line_event end_line(struct line_reader *reader)
{
    size_t length = reader->length;
    if (length && reader->line[length - 1] == '\r') {
        length--;
    }
    bool text = length && (uint8_t)reader->line[0] >= 0x20;
    if (reader->overflowed || (length && !text) || length > MAX_LINE) {
        reader->dropped++;
        reset(reader);
        return LINE_NONE;
    }
    reader->length = length;
    reader->line[length] = '\0';
    reader->complete = length != 0;
    return length ? LINE_TEXT : LINE_NONE;
}

static enum line_event frame_byte(struct line_reader *reader, uint8_t byte)
{
    if (byte != 0x00) {
        frame_decoder_byte(&reader->decoder, byte);
        return LINE_NONE;
    }
    if (!frame_decoder_heard(&reader->decoder)) {
        return LINE_NONE; /* two 0x00 in a row: still in a frame (how a stream resynchronises) */
    }
    reader->in_frame = false;
    reader->length = frame_decoder_end(&reader->decoder);
    if (!reader->length) {
        reader->dropped++;
        return LINE_NONE;
    }
    reader->complete = true; /* the next byte starts afresh */
    return LINE_BINARY;
}

enum line_event line_reader_feed(struct line_reader *reader, uint8_t byte)
{
    if (reader->complete) { /* the line handed out last was taken: start the next */
        reset(reader);
        reader->complete = false;
    }
    if (reader->in_frame) {
        return frame_byte(reader, byte);
    }
    if (byte == 0x00) { /* a frame opens: a line cut off before it is garbage */
        if (reader->length && !reader->overflowed) {
            reader->dropped++;
        }
        reset(reader);
        reader->in_frame = true;
        frame_decoder_start(&reader->decoder, reader->frame, sizeof reader->frame);
        return LINE_NONE;
    }
    if (byte == '\n') {
        enum line_event event = end_line(reader);
        if (event == LINE_NONE) {
            reset(reader);
        }
        return event;
    }
    if (reader->overflowed) {
        return LINE_NONE;
    }
    if (reader->length >= MAX_LINE + 1) { /* one past the limit: a '\r' may still come */
        reader->overflowed = true;
        reader->dropped++;
        return LINE_NONE;
    }
    reader->line[reader->length++] = (char)byte;
    return LINE_NONE;
}
