/*
 * receiver_harness.c - the node's main loop on the host: bytes from stdin, answers on stdout,
 * with a few directives for tests (tests/firmware/test_host_fuzz.py).
 *
 * The bytes go through the same line reader and receiver as on QEMU, in both modes. With
 * --directives, a line that starts with STX (0x02) is the harness's, not the node's:
 *   STX R        restart: the node boots again from its flash (what a reset leaves)
 *   STX T        the clock moves on 61 s (idle transfers expire)
 *   STX C N      the power fails during the N-th next flash operation (then STX R restores it)
 *   STX S PATH   the flash written to the file PATH (the test reads its directory)
 *   STX L PATH   the flash read from the file PATH, then a restart (a state to start from)
 *   STX P        `#pending` when a planned power cut is still to come, before the `#ok`
 * Each directive is answered `#ok`. Without --directives the stream is passed on untouched.
 *
 * The node harness (node_harness.c) is this loop with the kernel and the control requests
 * linked in: it defines harness_start and harness_step, which do nothing here.
 */
#include "../board/board.h"
#include "../loader/flash_layout.h"
#include "../loader/node.h"
#include "../protocol/line_reader.h"
#include "../protocol/receiver.h"
#include "harness.h"
#include "host_board.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static struct line_reader reader;

/* harness.h: nothing here; the node harness's kernel where it is linked in. */
__attribute__((weak)) void harness_start(void) {}
__attribute__((weak)) void harness_step(void (*send)(const char *bytes, size_t length))
{
    (void)send;
}

static void send_bytes(const char *bytes, size_t length)
{
    board_uart_write((const uint8_t *)bytes, length);
}

static void say(const char *line)
{
    printf("%s\n", line);
    fflush(stdout);
}

static void boot(void)
{
    board_init();
    if (!flash_layout_init()) {
        fprintf(stderr, "host board: flash geometry refused\n");
        exit(2);
    }
    harness_start();
    node_boot(say);
    receiver_init(send_bytes);
    line_reader_init(&reader);
    say("refresh-node host ready");
}

static void directive(const char *line)
{
    if (line[1] == 'R') {
        host_board_restore_power();
        boot();
    } else if (line[1] == 'T') {
        host_board_advance(61000000ull);
        receiver_expire();
    } else if (line[1] == 'C') {
        host_board_cut_power_after((uint32_t)strtoul(line + 2, 0, 10));
    } else if (line[1] == 'S') {
        host_board_save(line + 3);
    } else if (line[1] == 'P') {
        if (host_board_cut_pending()) {
            say("#pending");
        }
    } else if (line[1] == 'L') {
        host_board_load(line + 3);
        host_board_restore_power();
        boot();
    }
    harness_step(send_bytes);
    say("#ok");
}

/* A directive line: STX, then its text up to the line end. */
static void read_directive(void)
{
    char line[512] = {0x02};
    size_t length = 1;
    uint8_t byte;
    while (board_uart_read(&byte) && byte != '\n') {
        if (length + 1 < sizeof line) {
            line[length++] = (char)byte;
        }
    }
    line[length] = '\0';
    directive(line);
}

int main(int argc, char **argv)
{
    int directives = argc > 1 && strcmp(argv[1], "--directives") == 0;
    boot();
    uint8_t byte;
    int line_start = 1;
    while (board_uart_read(&byte)) {
        if (directives && line_start && byte == 0x02) {
            read_directive();
            continue;
        }
        enum line_event event = line_reader_feed(&reader, byte);
        /* A directive starts a line, never inside a binary frame, whose bytes may hold 0x02
         * after 0x0A; a frame's closing 0x00 is a line's start too. */
        line_start = !reader.in_frame && (byte == '\n' || byte == 0x00);
        if (event == LINE_TEXT) {
            receiver_handle_line(reader.line, reader.length);
        } else if (event == LINE_BINARY) {
            receiver_handle_binary(reader.frame, reader.length);
        }
        if (event != LINE_NONE) {
            harness_step(send_bytes);
        }
    }
    return 0;
}
