/*
 * main.c - the node firmware: boot the flash directory, say so on the link, then serve.
 *
 * One loop, no interrupt handler: poll the UART, hand each whole line to the receiver, drop
 * idle transfers; between lines, start the modules that arrived, run the kernel's due job and
 * push what a watch is due; once the host has been quiet for a while, sleep (board_idle) until
 * the next of those is due or a byte arrives. A job runs in one piece (the watchdog bounds it,
 * trap.h): bytes that arrive meanwhile wait in the UART, which QEMU does not overrun (it
 * flow-controls the socket behind it; a real board needs an interrupt-fed ring buffer).
 *
 * The banner is the first line a host sees after a reset; lines about modules skipped at boot
 * come before it. It is no protocol message, so a host that reads it as an answer drops it as
 * one it cannot decode.
 *
 * Until the first byte from the host arrives the banner is said again every 50 ms: a line
 * that no one listened to (QEMU drops what the guest writes to a pty nobody holds open, a real
 * board's host may plug in late) is said again, and a launcher needs no luck to hear it.
 */
#include "../board/board.h"
#include "../control/watch.h"
#include "../kernel/kernel.h"
#include "../kernel/text.h"
#include "../loader/flash_layout.h"
#include "../loader/node.h"
#include "../protocol/line_reader.h"
#include "../protocol/receiver.h"
#include "runtime.h"

#define BANNER_MAX 200
#define BANNER_EVERY_US 50000u
/* The longest sleep: idle transfers are dropped and an unheard banner said again on time. */
#define IDLE_MAX_US 10000u
/* How long the loop polls on after the last byte before it sleeps: a host's next message
 * comes soon within a transfer or a command, and a wake-up per byte would halve the install
 * rate on QEMU (benchmarks/firmware.py). */
#define AWAKE_AFTER_BYTE_US 10000u

static struct line_reader reader;

static void send_bytes(const char *bytes, size_t length)
{
    board_uart_write((const uint8_t *)bytes, length);
}

static void say(const char *line)
{
    send_bytes(line, text_length(line, 400));
    send_bytes("\n", 1);
}

static void banner(void)
{
    char text[BANNER_MAX];
    struct text line;
    text_start(&line, text, sizeof text);
    text_format(&line, "refresh-node %s ready: ", board_name());
    node_describe(&line);
    say(text);
}

/* Sleep until the next job or push is due, IDLE_MAX_US at most, or until a byte arrives. */
static void idle(void)
{
    const uint64_t now = kernel_time_us();
    uint64_t wake = now + IDLE_MAX_US, due;
    if (kernel_next_release(&due) && due < wake) {
        wake = due;
    }
    if (watch_next(&due) && due < wake) {
        wake = due;
    }
    board_idle(board_time_us() + (wake > now ? wake - now : 0));
}

static void serve(void)
{
    bool heard = false;
    uint64_t announced = board_time_us(), last_byte = 0;
    for (;;) {
        uint8_t byte;
        if (!board_uart_read(&byte)) {
            runtime_step();
            watch_push(send_bytes);
            receiver_expire();
            if (!heard && board_time_us() - announced >= BANNER_EVERY_US) {
                banner();
                announced = board_time_us();
            }
            if (board_time_us() - last_byte >= AWAKE_AFTER_BYTE_US) {
                idle();
            }
            continue;
        }
        heard = true;
        last_byte = board_time_us();
        enum line_event event = line_reader_feed(&reader, byte);
        if (event == LINE_TEXT) {
            receiver_handle_line(reader.line, reader.length);
        } else if (event == LINE_BINARY) {
            receiver_handle_binary(reader.frame, reader.length);
        }
        if (event != LINE_NONE) {
            runtime_step(); /* a stream of messages (a transfer) leaves room for due jobs */
        }
    }
}

int main(void)
{
    board_init();
    if (!flash_layout_init()) {
        say("refresh-node: the board's flash geometry does not fit this firmware; halted");
        return 1;
    }
    runtime_init(); /* before the boot: each intact module's init runs as it is found */
    node_boot(say);
    receiver_init(send_bytes);
    line_reader_init(&reader);
    banner();
    serve();
    return 0;
}
