/* control_text.c - the free text of control answers (control_text.h). */
#include "control_text.h"

#include "../kernel/kernel.h"

#define NODE_NAME "node" /* firmware-sim listen's default --name */

void control_add_signed(struct text *text, int64_t value)
{
    if (value < 0) {
        text_format(text, "-%U", (uint64_t)0 - (uint64_t)value);
        return;
    }
    text_add_unsigned(text, (uint64_t)value);
}

/* The digits of `thousandths` (0..999) after the point, at most `decimals`, trailing zeros
 * dropped; nothing at all when they are all zero. */
static void add_fraction(struct text *text, uint32_t thousandths, bool keep_one)
{
    char digits[4] = {(char)('0' + thousandths / 100u), (char)('0' + thousandths / 10u % 10u),
                      (char)('0' + thousandths % 10u), 0};
    int length = 3;
    while (length > (keep_one ? 1 : 0) && digits[length - 1] == '0') {
        length--;
    }
    if (length > 0) {
        text_add_char(text, '.');
        text_add_bytes(text, digits, (uint32_t)length);
    }
}

void control_add_hertz(struct text *text, uint32_t millihertz)
{
    uint32_t whole = millihertz / 1000u;
    uint32_t thousandths = millihertz % 1000u;
    /* %g keeps 6 significant digits: a rate of 10 kHz or more keeps 1 or no decimal */
    if (whole >= 100000u) {
        whole += thousandths >= 500u ? 1u : 0u;
        thousandths = 0;
    } else if (whole >= 10000u) {
        thousandths = (thousandths + 50u) / 100u * 100u;
        if (thousandths == 1000u) {
            whole++, thousandths = 0;
        }
    }
    text_add_unsigned(text, whole);
    add_fraction(text, thousandths, false);
}

void control_add_milli(struct text *text, int64_t milli)
{
    uint64_t magnitude = milli < 0 ? (uint64_t)0 - (uint64_t)milli : (uint64_t)milli;
    if (milli < 0) {
        text_add_char(text, '-');
    }
    text_add_unsigned(text, magnitude / 1000u);
    add_fraction(text, (uint32_t)(magnitude % 1000u), true);
}

/* The names of `pbo`'s ports of one direction, comma-separated. */
static void add_ports(struct text *text, const struct kernel_pbo *pbo, uint8_t direction)
{
    bool first = true;
    for (uint32_t port = 0; port < pbo->port_count; port++) {
        if (pbo->port_directions[port] == direction) {
            text_format(text, "%s%s", first ? "" : ",", pbo->port_names[port]);
            first = false;
        }
    }
}

void control_pbo_rows(struct text *text)
{
    struct kernel_pbo pbo;
    for (uint32_t index = 0; kernel_pbo_at(index, &pbo); index++) {
        text_format(text, "%s%s:%s:", index == 0 ? "" : " ", pbo.name, pbo.state);
        control_add_hertz(text, pbo.millihertz);
        for (uint8_t direction = 0; direction < 3; direction++) { /* IN, OUT, CONST */
            text_add_char(text, ':');
            add_ports(text, &pbo, direction);
        }
    }
}

/* A JSON string as json.dumps writes it with ensure_ascii (a byte above 0x7F as its Latin-1
 * code point: the Python node decodes module text so). */
static void add_json_string(struct text *text, const char *string, uint32_t length)
{
    static const char HEX[] = "0123456789abcdef";
    text_add_char(text, '"');
    for (uint32_t i = 0; i < length; i++) {
        uint8_t c = (uint8_t)string[i];
        const char *escape = c == '"' ? "\\\"" : c == '\\' ? "\\\\" : c == '\n' ? "\\n"
                             : c == '\r' ? "\\r" : c == '\t' ? "\\t" : c == '\b' ? "\\b"
                             : c == '\f' ? "\\f" : 0;
        if (escape != 0) {
            text_add(text, escape);
        } else if (c < 0x20 || c >= 0x80) {
            text_add(text, "\\u00");
            text_add_char(text, HEX[c >> 4]);
            text_add_char(text, HEX[c & 0xFu]);
        } else {
            text_add_char(text, (char)c);
        }
    }
    text_add_char(text, '"');
}

static uint32_t json_string_length(const char *string, uint32_t length)
{
    char scratch[8];
    uint32_t total = 2;
    for (uint32_t i = 0; i < length; i++) {
        struct text one;
        text_start(&one, scratch, sizeof scratch);
        add_json_string(&one, string + i, 1);
        total += (uint32_t)one.length - 2u;
    }
    return total;
}

/* Log lines: log_text's rule. The oldest lines that fit the budget, the first one cut in half
 * until it fits. */
struct log_writer {
    struct text *text;
    uint32_t taken;
    bool full;
};

static uint32_t decimal_length(uint64_t value)
{
    uint32_t digits = 1;
    while (value >= 10u) {
        value /= 10u, digits++;
    }
    return digits;
}

/* `[N, US, "TEXT"]`: its length in JSON. */
static uint32_t entry_length(const struct log_line *line, uint32_t length)
{
    return 1u + decimal_length(line->number) + 2u + decimal_length(line->time_us) + 2u +
           json_string_length(line->text, length) + 1u;
}

static void take_line(const struct log_line *line, void *context)
{
    struct log_writer *writer = context;
    uint32_t length = line->length;
    /* what the array would then hold: "[" entries joined by ", " "]" */
    uint32_t total = (uint32_t)writer->text->length + (writer->taken ? 2u : 1u) + 1u;

    if (writer->full) {
        return;
    }
    if (writer->taken && total + entry_length(line, length) > CONTROL_TEXT_MAX) {
        writer->full = true;
        return;
    }
    while (total + entry_length(line, length) > CONTROL_TEXT_MAX && length > 1u) {
        length /= 2u; /* Python keeps text[: len(text) // 2] */
    }
    text_format(writer->text, "%s%U, %U, ", writer->taken ? ", [" : "[[", (uint64_t)line->number,
                (uint64_t)line->time_us);
    add_json_string(writer->text, line->text, length);
    text_add_char(writer->text, ']');
    writer->taken++;
}

bool control_log_latest(const char *name, uint32_t *latest)
{
    struct kernel_stats stats;
    if (kernel_stats(name, &stats) != KERNEL_OK) {
        return false;
    }
    *latest = stats.logged;
    return true;
}

void control_log_lines(struct text *text, const char *name, uint32_t since)
{
    struct log_writer writer = {text, 0, false};
    (void)kernel_log(name, since, take_line, &writer);
    if (writer.taken) {
        text_add_char(text, ']');
    }
}

/* The description with the first `wires` wires and `constants` constants, the failure cut
 * to `failure` characters. */
static void add_description(struct text *text, const char *name, uint32_t constants,
                            uint32_t wires, uint32_t failure)
{
    struct kernel_pbo pbo;
    struct kernel_stats stats;
    char source[32], sink[32];
    uint32_t listed = 0;

    text_add(text, "{\"name\": ");
    add_json_string(text, name, (uint32_t)text_length(name, 64));
    text_add(text, ", \"constants\": [");
    for (uint32_t index = 0; kernel_pbo_at(index, &pbo); index++) {
        for (uint32_t port = 0; text_equal(pbo.name, name) && port < pbo.port_count; port++) {
            char full[48];
            struct text port_name;
            int32_t value;
            if (pbo.port_directions[port] < 2 || listed == constants) {
                continue; /* IN and OUT: not constants */
            }
            text_add(text, listed++ ? ", [" : "[");
            add_json_string(text, pbo.port_names[port],
                            (uint32_t)text_length(pbo.port_names[port], 16));
            text_add(text, ", ");
            text_start(&port_name, full, sizeof full);
            text_format(&port_name, "%s.%s", name, pbo.port_names[port]);
            if (pbo.port_kinds[port] != 0) {
                text_add(text, pbo.port_kinds[port] == 1 ? "\"vector\"" : "\"frame\"");
            } else if (kernel_read(full, &value) == KERNEL_OK) {
                control_add_signed(text, value);
            }
            text_add_char(text, ']');
        }
    }
    text_add(text, "], \"wires\": [");
    for (uint32_t n = 0; n < wires && kernel_wire_at(name, n, source, sink); n++) {
        text_format(text, "%s%s=%s", n ? ", \"" : "\"", source, sink);
        text_add_char(text, '"');
    }
    text_add(text, "], \"last_failure\": ");
    (void)kernel_stats(name, &stats);
    if (stats.last_failure[0] == '\0') {
        text_add(text, "null}");
        return;
    }
    add_json_string(text, stats.last_failure,
                    (uint32_t)text_length(stats.last_failure, failure));
    text_add_char(text, '}');
}

bool control_description(struct text *text, const char *name)
{
    struct kernel_stats stats;
    const uint32_t start = text->length;
    uint32_t constants = 8, wires = 64, failure = 1024;

    if (kernel_stats(name, &stats) != KERNEL_OK) {
        return false;
    }
    /* description_text's cut: wires first, then constants, then the failure's end; each try
     * is written over the last */
    for (;;) {
        text->length = start;
        text->buffer[start] = '\0';
        add_description(text, name, constants, wires, failure);
        if (text->length - start <= CONTROL_TEXT_MAX || failure == 200u) {
            return true;
        }
        uint32_t wired = 0;
        char source[32], sink[32];
        while (wired < wires && kernel_wire_at(name, wired, source, sink)) {
            wired++;
        }
        if (wired > 0) {
            wires = wired - 1u;
        } else if (constants > 0) {
            constants--;
        } else {
            failure = 200u;
        }
    }
}

void control_state_line(struct text *text)
{
    static const char *const STATES[] = {"ERROR", "KILLED", "NOT_CREATED", "OFF", "ON"};
    struct kernel_pbo pbo;
    uint32_t count = kernel_pbo_count();
    bool first = true;

    text_format(text, NODE_NAME ": %U PBOs", (uint64_t)count);
    for (uint32_t s = 0; s < sizeof STATES / sizeof STATES[0]; s++) { /* sorted, as Python */
        uint32_t in_state = 0;
        for (uint32_t index = 0; kernel_pbo_at(index, &pbo); index++) {
            in_state += text_equal(pbo.state, STATES[s]) ? 1u : 0u;
        }
        if (in_state) {
            text_format(text, "%s%U %s", first ? ": " : ", ", (uint64_t)in_state, STATES[s]);
            first = false;
        }
    }
}
