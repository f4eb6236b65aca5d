/*
 * binary_frame.c - COBS frames on the stream, and CRC-16/CCITT (binary_frame.h).
 */
#include "binary_frame.h"

#define TEXT_FIRST_BYTE 0x20 /* a binary message's type is below it (hexmigrate.links.base) */

void frame_decoder_start(struct frame_decoder *decoder, uint8_t *buffer, size_t capacity)
{
    *decoder = (struct frame_decoder){.buffer = buffer, .capacity = capacity};
}

static void keep(struct frame_decoder *decoder, uint8_t byte)
{
    if (decoder->length >= decoder->capacity) {
        decoder->overflowed = true; /* dropped whole at its end; the rest is only counted */
        return;
    }
    decoder->buffer[decoder->length++] = byte;
}

void frame_decoder_byte(struct frame_decoder *decoder, uint8_t byte)
{
    decoder->heard = true;
    if (decoder->overflowed) {
        return;
    }
    if (decoder->run_left) {
        keep(decoder, byte);
        decoder->run_left--;
        return;
    }
    /* A code byte: the 0x00 the previous run stood for is real, since the frame goes on. */
    if (decoder->zero_after) {
        keep(decoder, 0x00);
    }
    decoder->run_left = (uint8_t)(byte - 1u);
    decoder->zero_after = byte <= COBS_RUN;
}

bool frame_decoder_heard(const struct frame_decoder *decoder)
{
    return decoder->heard;
}

size_t frame_decoder_end(struct frame_decoder *decoder)
{
    /* A run cut short by the frame's end is no COBS (cobs_decode refuses it). */
    bool valid = !decoder->overflowed && decoder->run_left == 0 && decoder->length &&
                 decoder->buffer[0] < TEXT_FIRST_BYTE;
    return valid ? decoder->length : 0;
}

static const char DELIMITER = 0x00;

static void send_run(struct frame_writer *writer)
{
    char code = (char)(writer->length + 1u);
    writer->send(&code, 1);
    writer->send((const char *)writer->run, writer->length);
    writer->length = 0;
}

void frame_writer_start(struct frame_writer *writer,
                        void (*send)(const char *bytes, size_t length))
{
    writer->send = send;
    writer->length = 0;
    writer->after_full = false;
    send(&DELIMITER, 1);
}

void frame_writer_put(struct frame_writer *writer, const uint8_t *bytes, size_t length)
{
    for (size_t i = 0; i < length; i++) {
        writer->after_full = false;
        if (bytes[i] == 0x00) {
            send_run(writer); /* its code stands for this 0x00 */
            continue;
        }
        writer->run[writer->length++] = bytes[i];
        if (writer->length == COBS_RUN) {
            send_run(writer); /* code 0xFF: no 0x00 after it */
            writer->after_full = true;
        }
    }
}

void frame_writer_end(struct frame_writer *writer)
{
    if (!writer->after_full) {
        send_run(writer); /* the last run, even an empty one; its code stands for no 0x00 */
    }
    writer->send(&DELIMITER, 1);
}

uint16_t crc16_ccitt(const uint8_t *data, size_t length)
{
    uint16_t crc = 0xFFFF;
    for (size_t i = 0; i < length; i++) {
        crc ^= (uint16_t)(data[i] << 8);
        for (int bit = 0; bit < 8; bit++) {
            unsigned shifted = (unsigned)crc << 1;
            crc = (uint16_t)((crc & 0x8000u) ? shifted ^ 0x1021u : shifted);
        }
    }
    return crc;
}
