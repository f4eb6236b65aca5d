/*
 * binary_frame.c - COBS frames on the stream, and CRC-16/CCITT (binary_frame.h).
 */
#include "binary_frame.h"

#define COBS_RUN 254        /* the most non-zero bytes one code covers */
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

static void send_run(void (*send)(const char *bytes, size_t length), const uint8_t *run,
                     size_t length)
{
    char code = (char)(length + 1u);
    send(&code, 1);
    send((const char *)run, length);
}

/* framing.cobs_encode's canonical output, chunk by chunk (the pieces between 0x00 bytes): full
 * runs of 254, then the rest with its code, which also stands for the 0x00 after the chunk; a
 * message whose last chunk is a whole number of full runs ends with them. */
void binary_frame_send(void (*send)(const char *bytes, size_t length), const uint8_t *message,
                       size_t length)
{
    static const char DELIMITER = 0x00;
    send(&DELIMITER, 1);
    size_t chunk = 0;
    for (;;) {
        size_t end = chunk;
        while (end < length && message[end] != 0x00) {
            end++;
        }
        bool last = end == length;
        size_t start = chunk;
        for (; end - start >= COBS_RUN; start += COBS_RUN) {
            send_run(send, message + start, COBS_RUN);
        }
        if (start == chunk || start < end || !last) {
            send_run(send, message + start, end - start);
        }
        if (last) {
            break;
        }
        chunk = end + 1;
    }
    send(&DELIMITER, 1);
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
