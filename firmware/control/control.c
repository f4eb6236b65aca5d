/*
 * control.c - the node's control requests answered on the firmware's kernel (control.h), as
 * the Python node answers them: hexmigrate/transfer/receiver.py picks the answer,
 * firmware_sim/serving/kernel_control.py does the request. A refusal is `NAK TID 0 FATAL VERB
 * refused: REASON`, the reason in the Python node's words and cut to 200 characters as there.
 *
 * What this node cannot do is refused as a node without the feature refuses it: bridges to
 * other nodes (EXPORT, IMPORT) need a link of their own, and lock-step time (ADVANCE) a node
 * started for it.
 *
 * A request that changes the node, sent again because its answer was lost (the host's retry),
 * gets the answer it got, as on the Python node: START done twice would be refused the second
 * time, and the host would report a failure that did not happen. The answers of the last
 * REMEMBERED such requests are kept, by their decoded fields (a binary request has no line);
 * the Python node keeps 64 of every request, and the reads done again change nothing.
 */
#include "control.h"

#include <stdarg.h>

#include "../kernel/abi.h"
#include "../kernel/kernel.h"
#include "../lib/crc.h"
#include "../main/runtime.h"
#include "../protocol/answer_memory.h"
#include "../protocol/number_word.h"
#include "control_text.h"
#include "ports.h"
#include "setting.h"
#include "watch.h"

#define MAX_REFUSAL 200   /* receiver.py's MAX_REFUSAL */
#define RATE_MIN_MHZ 10u  /* 0.01 Hz: node.py's RATE_MIN */
#define RATE_MAX_MHZ 100000000u

/* refuse's format for a reason written already. An array, not a literal: the linker merges a
 * literal "%s" with the kernel's, which benchmarks/firmware.py's parts would count twice. */
static const char REASON[] = "%s";

/* One request being answered: its line, its tid, where the answer goes. */
struct request {
    const struct message *message;
    uint32_t tid;
    struct text *reply;
};

/* Field `field`'s word as a name (ports_name: cut where no refusal shows it any more). */
static const char *field_name(const struct request *r, int field)
{
    return ports_name(0, r->message->text[field], r->message->text_length[field]);
}

/* The refusal, its reason written by `format` (text_format's conversions): written here, so
 * that no handler needs a buffer of a refusal's length for it. Apart from the handlers (never
 * inlined), so that its text is on the stack only while it writes, not while the kernel runs a
 * module's method for the request. */
__attribute__((noinline)) static bool refuse(const struct request *r, const char *format, ...)
{
    char text[MAX_REFUSAL + 56];
    struct text why;
    va_list arguments;

    text_start(&why, text, sizeof text);
    text_format(&why, "%s refused: ", verb_word(r->message->verb));
    va_start(arguments, format);
    text_vformat(&why, format, arguments);
    va_end(arguments);
    if (why.length > MAX_REFUSAL) { /* the reason's start, and "..." to say it goes on */
        text_copy(text + MAX_REFUSAL - 3, "...", 4);
    }
    reply_nak(r->reply, r->tid, 0, true, text);
    return true;
}

static bool acknowledge(const struct request *r, const char *text)
{
    reply_ack(r->reply, r->tid, 0, text);
    return true;
}

/* The kernel's answer: `said` ("started gain") when it did it, else its reason. */
static bool kernel_answer(const struct request *r, int result, const char *said)
{
    return result == KERNEL_OK ? acknowledge(r, said) : refuse(r, REASON, kernel_message());
}

/* START, STOP, CLEAR: the PBO named in field 1, and what the ACK says. */
static bool lifecycle(const struct request *r)
{
    const char *name = field_name(r, 1);
    char said[ABI_NAME_LEN + 24]; /* the ACK: said of a PBO there is, whose name is 16 at most */
    struct text text;
    int result;

    text_start(&text, said, sizeof said);
    if (r->message->verb == VERB_START) {
        result = kernel_start(name);
        text_format(&text, "started %s", name);
    } else if (r->message->verb == VERB_STOP) {
        result = kernel_stop(name);
        text_format(&text, "stopped %s", name);
    } else {
        result = kernel_clear(name);
        text_format(&text, "cleared %s: now OFF", name);
    }
    return kernel_answer(r, result, said);
}

static bool list_pbos(const struct request *r)
{
    struct text rows;
    reply_text_start(r->reply, VERB_PBOS, &r->tid, &rows);
    control_pbo_rows(&rows);
    reply_text_end(r->reply, &rows);
    return true;
}

/* The port's row in PS (direction, element size, kind): what the kernel's SET does not say
 * of a port when the value is a fraction it cannot take at all. */
static bool port_row(const char *port, uint8_t *direction, uint16_t *size, uint8_t *kind)
{
    struct kernel_pbo pbo;
    char full[PORT_NAME_MAX + 1];
    struct text name;

    for (uint32_t index = 0; kernel_pbo_at(index, &pbo); index++) {
        for (uint32_t p = 0; p < pbo.port_count; p++) {
            text_start(&name, full, sizeof full);
            text_format(&name, "%s.%s", pbo.name, pbo.port_names[p]);
            if (text_equal(full, port)) {
                *direction = pbo.port_directions[p];
                *size = pbo.element_sizes[p];
                *kind = pbo.port_kinds[p];
                return true;
            }
        }
    }
    return false;
}

/* VALUE as Python shows the number it read: an integer in decimal, a float as given. */
static void show_value(const struct setting *setting, struct text *why)
{
    struct number_word number;
    if (setting->whole && number_word_parse(setting->text, setting->text_length, &number)) {
        number_word_show(setting->text, setting->text_length, &number, why);
        return;
    }
    setting_show(setting, why);
}

/* A value the kernel cannot take at all (a fraction, or past 64 bits): refused after the
 * checks the kernel makes first, as port_values.py's exact() refuses it. */
static bool refuse_value(const struct request *r, const struct setting *setting)
{
    static const char *const DIRECTIONS[] = {"in", "out", "const", "resource"};
    char text[MAX_REFUSAL + 56];
    struct text why;
    uint8_t direction, kind;
    uint16_t size;
    int32_t ignored;

    if (!port_row(setting->port, &direction, &size, &kind)) {
        (void)kernel_read(setting->port, &ignored); /* says "unknown PBO" or "unknown port" */
        return refuse(r, REASON, kernel_message());
    }
    text_start(&why, text, sizeof text);
    text_add(&why, setting->port);
    if (direction != 2) {
        text_format(&why, " is an %s port, not a constant", DIRECTIONS[direction & 3u]);
        return refuse(r, REASON, text);
    }
    if (kind != 0) {
        (void)kernel_set_constant(setting->port, 0); /* refuses a vector by its kind */
        return refuse(r, REASON, kernel_message());
    }
    text_add(&why, size == 1   ? " is uint8 (a whole number from 0 to 255), got "
                     : size == 2 ? " is int16 (a whole number from -32768 to 32767), got "
                                 : " is int32 (a whole number from -2147483648 to "
                                   "2147483647), got ");
    show_value(setting, &why);
    if (!setting->whole) {
        text_add(&why, ": give a fixed-point constant as its raw integer (0x8000 is 0.5 in "
                         "Q16.16)");
    }
    return refuse(r, REASON, text);
}

static bool set_constant(const struct request *r)
{
    struct setting setting;
    char reason[MAX_REFUSAL + 56], said[96];
    struct text why, text;

    text_start(&why, reason, sizeof reason);
    if (!setting_parse(r->message->text[1], r->message->text_length[1], &setting, &why)) {
        return refuse(r, REASON, reason);
    }
    if (!setting.whole || setting.too_large) {
        return refuse_value(r, &setting);
    }
    if (kernel_set_constant(setting.port, setting.value) != KERNEL_OK) {
        return refuse(r, REASON, kernel_message());
    }
    text_start(&text, said, sizeof said);
    text_format(&text, "set %s=", setting.port);
    control_add_signed(&text, setting.value);
    return acknowledge(r, said);
}

static bool set_rate(const struct request *r)
{
    const uint32_t millihertz = (uint32_t)r->message->number[1];
    const char *name = field_name(r, 2);
    char said[ABI_NAME_LEN + 32]; /* the ACK of a PBO there is, or the refused rate's digits */
    struct text text;

    text_start(&text, said, sizeof said);
    if (millihertz < RATE_MIN_MHZ || millihertz > RATE_MAX_MHZ) {
        control_add_milli(&text, millihertz); /* every digit, as Python's repr of the rate */
        return refuse(r, "PBO %q: expected a rate of 0.01 to 100000 Hz, got %s", name, said);
    }
    text_format(&text, "rate %s=", name);
    control_add_hertz(&text, millihertz);
    text_add(&text, " Hz");
    return kernel_answer(r, kernel_set_rate(name, millihertz), said);
}

/* CONNECT, DISCONNECT: OUT_PBO.port=IN_PBO.port. */
static bool wire(const struct request *r)
{
    const char *text = r->message->text[1];
    const size_t length = r->message->text_length[1];
    const char *source, *sink;
    char said[2 * PORT_NAME_MAX + 16]; /* the ACK: "disconnected OUT=IN" of two ports there are */
    struct text why;
    size_t equals = 0;
    bool connect = r->message->verb == VERB_CONNECT;

    while (equals < length && text[equals] != '=') {
        equals++;
    }
    if (equals == length || !ports_is_port(text, equals) ||
        !ports_is_port(text + equals + 1, length - equals - 1)) {
        return refuse(r, "expected OUT_PBO.port=IN_PBO.port, got %r", text,
                      (uint32_t)(length > 60 ? 60 : length));
    }
    source = ports_name(0, text, equals);
    sink = ports_name(1, text + equals + 1, length - equals - 1);
    text_start(&why, said, sizeof said);
    text_add(&why, connect ? "connected " : "disconnected ");
    text_add_bytes(&why, text, length);
    return kernel_answer(r, connect ? kernel_connect(source, sink)
                                    : kernel_disconnect(source, sink), said);
}

static bool read_ports(const struct request *r)
{
    struct port_list ports;
    char reason[MAX_REFUSAL + 1];
    struct text why, values;

    text_start(&why, reason, sizeof reason);
    if (!ports_parse(r->message->text[1], r->message->text_length[1], PORTS_MAX, &ports, &why) ||
        !ports_readable(&ports, &why)) {
        return refuse(r, REASON, reason);
    }
    reply_text_start(r->reply, VERB_VALUES, &r->tid, &values);
    ports_add_values(&ports, &values);
    reply_text_end(r->reply, &values);
    return true;
}

static bool log_lines(const struct request *r)
{
    const char *name = field_name(r, 2);
    struct text lines;
    uint32_t numbers[2] = {r->tid, 0};

    if (!control_log_latest(name, &numbers[1])) {
        return refuse(r, REASON, kernel_message());
    }
    reply_text_start(r->reply, VERB_LOGLINES, numbers, &lines);
    control_log_lines(&lines, name, (uint32_t)r->message->number[1]);
    reply_text_end(r->reply, &lines);
    return true;
}

static bool describe(const struct request *r)
{
    const char *name = field_name(r, 1);
    struct text description;

    reply_text_start(r->reply, VERB_DESCRIPTION, &r->tid, &description);
    if (!control_description(&description, name)) {
        text_start(r->reply, r->reply->buffer, r->reply->capacity); /* the refusal instead */
        return refuse(r, REASON, kernel_message());
    }
    reply_text_end(r->reply, &description);
    return true;
}

static bool hold(const struct request *r)
{
    const char *name = field_name(r, 1);
    char said[MAX_REFUSAL];
    struct text text;
    text_start(&text, said, sizeof said);
    return runtime_hold(name, &text) ? acknowledge(r, said) : refuse(r, REASON, said);
}

static bool reset(const struct request *r)
{
    uint32_t switched_off, wires;
    char said[120];
    struct text text;

    kernel_reset(&switched_off, &wires);
    runtime_forget_holds();
    watch_restart(); /* the watch follows the clock's restart */
    text_start(&text, said, sizeof said);
    text_format(&text, "reset: %U PBO(s) switched off, %U wire(s) and 0 bridge(s) undone, clock "
                "at 0 s", (uint64_t)switched_off, (uint64_t)wires);
    return acknowledge(r, said);
}

static bool watch(const struct request *r)
{
    char reason[MAX_REFUSAL + 56];
    struct text why;
    text_start(&why, reason, sizeof reason);
    return watch_request(r->message, r->reply, &why) || refuse(r, REASON, reason);
}

static bool changes_the_node(enum verb verb)
{
    return verb == VERB_START || verb == VERB_STOP || verb == VERB_CLEAR || verb == VERB_SET ||
           verb == VERB_RATE || verb == VERB_CONNECT || verb == VERB_DISCONNECT ||
           verb == VERB_HOLD || verb == VERB_RESET || verb == VERB_WATCH;
}

/* The request's identity: its verb and every field, as the Python node compares messages. */
static uint32_t request_key(const struct message *request)
{
    uint32_t key = crc32_update(0, &request->verb, sizeof request->verb);
    for (int i = 0; i < MESSAGE_MAX_FIELDS; i++) {
        if (request->present[i]) {
            key = crc32_update(key, &request->number[i], sizeof request->number[i]);
            key = crc32_update(key, request->text[i], request->text_length[i]);
        }
    }
    return key;
}

static bool answer(const struct message *request, struct text *reply);

bool node_control(const struct message *request, struct text *reply)
{
    const uint32_t key = changes_the_node(request->verb) ? request_key(request) : 0;

    if (key != 0 && answer_memory_find(key, reply)) {
        return true;
    }
    if (!answer(request, reply)) {
        return false;
    }
    if (key != 0) {
        answer_memory_keep(key, reply->buffer, reply->length);
    }
    return true;
}

static bool answer(const struct message *request, struct text *reply)
{
    const struct request r = {request, (uint32_t)request->number[0], reply};

    switch (request->verb) {
    case VERB_PS: return list_pbos(&r);
    case VERB_START: case VERB_STOP: case VERB_CLEAR: return lifecycle(&r);
    case VERB_SET: return set_constant(&r);
    case VERB_RATE: return set_rate(&r);
    case VERB_CONNECT: case VERB_DISCONNECT: return wire(&r);
    case VERB_READ: return read_ports(&r);
    case VERB_LOGS: return log_lines(&r);
    case VERB_DESCRIBE: return describe(&r);
    case VERB_HOLD: return hold(&r);
    case VERB_RESET: return reset(&r);
    case VERB_WATCH: return watch(&r);
    case VERB_EXPORT: case VERB_IMPORT:
        return refuse(&r, "this node has no bridges: the firmware's one link is its host's "
                          "(run the PBOs that exchange ports on one node)");
    case VERB_ADVANCE:
        return refuse(&r, "this node runs on the real-time clock: the firmware has no "
                          "lock-step time");
    default: return false;
    }
}
