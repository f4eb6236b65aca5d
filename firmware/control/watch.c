/* watch.c - a host's watch and what it pushes (watch.h). */
#include "watch.h"

#include "../kernel/kernel.h"
#include "../protocol/binary_messages.h"
#include "../protocol/receiver.h"
#include "control_text.h"
#include "ports.h"

#define HEARTBEAT_US 1000000u
#define MIN_PERIOD_MS 10u

static struct {
    bool on;
    bool binary; /* pushed in binary mode: the watch came in it */
    uint32_t period_us;
    uint64_t next_report, next_beat, reported;
    uint32_t seq;
    struct port_list ports; /* in `kept`, or none */
    char kept[PORTS_TEXT_MAX];
} watch;

bool watch_request(const struct message *request, struct text *reply, struct text *why)
{
    const uint32_t tid = (uint32_t)request->number[0];
    const uint32_t period_ms = (uint32_t)request->number[1];
    struct port_list ports = {0, 0};

    if (period_ms == 0) {
        watch.on = false;
        reply_ack(reply, tid, 0, "unwatched");
        return true;
    }
    if (period_ms < MIN_PERIOD_MS) {
        text_format(why, "expected a report period of at least 10 ms, got %U", (uint64_t)period_ms);
        return false;
    }
    if (request->text_length[2] > 0 &&
        (!ports_parse(request->text[2], request->text_length[2], WATCH_PORTS_MAX, &ports, why) ||
         !ports_readable(&ports, why))) {
        return false; /* refused by name now rather than missing from every report */
    }
    watch.on = true;
    watch.binary = receiver_answering_binary();
    watch.period_us = period_ms * 1000u;
    watch.seq = 0;
    watch.ports = ports;
    ports_keep(&watch.ports, watch.kept);
    watch_restart(); /* the first report at once, the first beat a second on */
    reply_ack(reply, tid, period_ms, "watching");
    return true;
}

void watch_restart(void)
{
    uint64_t now = kernel_time_us();
    watch.next_report = now;
    watch.next_beat = now + HEARTBEAT_US;
    watch.reported = now;
}

/* leftover=.. slip=.. missed=.., then PBO:L, PBO:F0 .. of each PBO, then the watched ports. */
static void report_values(struct text *text)
{
    struct kernel_status status;
    struct kernel_pbo pbo;
    struct kernel_stats stats;

    kernel_status(watch.reported, &status);
    text_add(text, "leftover=");
    control_add_milli(text, status.leftover_milli);
    text_add(text, " slip=");
    control_add_milli(text, (int64_t)((status.slip_us + 50u) / 100u) * 100); /* 0.1 ms */
    text_format(text, " missed=%U", (uint64_t)status.missed);
    for (uint32_t index = 0; kernel_pbo_at(index, &pbo); index++) {
        uint8_t kind;
        uint32_t value_index;
        int32_t value;
        if (kernel_stats(pbo.name, &stats) == KERNEL_OK && stats.logged) {
            text_format(text, " %s:L=%U", pbo.name, (uint64_t)stats.logged);
        }
        for (uint32_t n = 0; kernel_performance_at(index, n, &kind, &value_index, &value); n++) {
            text_format(text, " %s%s%U=", pbo.name, kind == 0 ? ":F" : ":N", (uint64_t)value_index);
            control_add_milli(text, value);
        }
    }
    ports_add_values(&watch.ports, text);
}

/* A REPORT or a BEAT, its text written by `write`. */
static void push(void (*send)(const char *, size_t), enum verb verb, uint64_t now,
                 void (*write)(struct text *text))
{
    struct text line, text;
    const uint32_t numbers[2] = {watch.seq++, (uint32_t)(now / 1000u)};
    text_start(&line, answer_line, sizeof answer_line);
    reply_text_start(&line, verb, numbers, &text);
    write(&text);
    reply_text_end(&line, &text);
    if (watch.binary) {
        binary_send_line(send, line.buffer, line.length);
        return;
    }
    send(line.buffer, line.length);
}

void watch_push(void (*send)(const char *bytes, size_t length))
{
    uint64_t now;

    if (!watch.on) {
        return;
    }
    now = kernel_time_us();
    if (now >= watch.next_report) {
        watch.next_report += watch.period_us;
        if (watch.next_report <= now) { /* late by a period or more: one period from now */
            watch.next_report = now + watch.period_us;
        }
        push(send, VERB_REPORT, now, report_values);
        watch.reported = now;
    }
    if (now >= watch.next_beat) {
        watch.next_beat = now + HEARTBEAT_US;
        push(send, VERB_BEAT, now, control_state_line);
    }
}

bool watch_next(uint64_t *when_us)
{
    if (!watch.on) {
        return false;
    }
    *when_us = watch.next_report < watch.next_beat ? watch.next_report : watch.next_beat;
    return true;
}
