/*
 * session.c - sessions on a node that trusts no key (session.h).
 */
#include "session.h"

#include "../board/board.h"
#include "messages.h"

#define NONCE_WORDS 4 /* 32 bytes, 64 hex digits, as the Python node draws */

static struct {
    int challenged; /* a CHALLENGE waits for its AUTH */
    uint64_t state;
} session;

void session_reset(void)
{
    session.challenged = 0;
}

/* SplitMix64 over the clock: a nonce no one predicts from the last one. A node that checks
 * signatures (to come) wants the board's true random source here. */
static uint64_t next_random(void)
{
    uint64_t x = (session.state += 0x9E3779B97F4A7C15ull ^ board_time_us());
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

void session_challenge(uint32_t tid, struct text *reply)
{
    static const char HEX[] = "0123456789abcdef";
    char text[10 + 16 * NONCE_WORDS + 1];
    struct text nonce;
    text_start(&nonce, text, sizeof text);
    text_add(&nonce, "challenge ");
    for (int word = 0; word < NONCE_WORDS; word++) {
        uint64_t bits = next_random();
        for (int i = 0; i < 16; i++, bits >>= 4) {
            text_add_char(&nonce, HEX[bits & 0xFu]);
        }
    }
    session.challenged = 1;
    reply_ack(reply, tid, 0, text);
}

void session_authenticate(uint32_t tid, struct text *reply)
{
    if (!session.challenged) {
        reply_nak(reply, tid, 0, true,
                  "no challenge to answer on this connection: a host asks for one first "
                  "(hexmigrate --key does both), and a challenge serves one answer");
        return;
    }
    session.challenged = 0;
    reply_ack(reply, tid, 0, "authenticated: this node trusts no key, guards nothing");
}

void session_end(uint32_t tid, struct text *reply)
{
    session.challenged = 0;
    reply_ack(reply, tid, 0, "bye");
}
