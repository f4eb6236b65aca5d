/*
 * binary_messages.c - the binary codec (binary_messages.h).
 */
#include "binary_messages.h"

#include "../lib/crc.h"
#include "binary_frame.h"

#define EXTENDED 0x100u /* a declared code 0x1NN travels as 00 NN (layout.extended) */
#define CRC32_SIZE 4
#define CRC16_SIZE 2
#define MAX_LEADING_WORD 0xFF /* a word before the last of a tail: its length in one byte */
#define BLOCK 256u            /* a BlockAck counts flash blocks */
#define NO_ADDRESS 0xFFFFFFFFu
#define CANNOT_ANSWER_MAX 224 /* "cannot answer: " and a reason of at most 200 characters */

/* The field kinds of the types without a verb, after messages.h's. */
#define FIELD_U32_ARRAY (FIELD_LISTING + 1)
#define FIELD_PAYLOAD (FIELD_LISTING + 2)
#define FIELD_BLOCKS (FIELD_LISTING + 3) /* u16 on the wire, counted in 256-byte blocks */

#define TID {"tid", FIELD_U32}

/* The types without a verb, as messages.py declares them; by `enum binary_kind`. */
static const struct verb_spec BINARY_ONLY[] = {
    [BINARY_HEADER] = {"", 3, {TID, {"init", FIELD_U32}, {"relocations", FIELD_U32_ARRAY}}},
    [BINARY_DATA] = {"", 3, {TID, {"address", FIELD_U32}, {"payload", FIELD_PAYLOAD}}},
    [BINARY_SIGNATURE] = {"", 3, {TID, {"offset", FIELD_U32}, {"area", FIELD_PAYLOAD}}},
    [BINARY_BLOCK_ACK] = {"", 2, {{"tag", FIELD_U16}, {"value", FIELD_BLOCKS}}},
};

/* Every binary type, by code, with its class name in messages.py (refusals name it). */
struct binary_type {
    uint16_t code;
    uint8_t kind;
    int8_t verb; /* for BINARY_VERB */
    const char *name;
};

#define V(code, verb, name) {code, BINARY_VERB, verb, name}
static const struct binary_type TYPES[] = {
    V(0x01, VERB_PING, "Ping"), V(0x02, VERB_LS, "ListModules"), V(0x03, VERB_RM, "Remove"),
    V(0x04, VERB_BEGIN, "Begin"), {0x05, BINARY_HEADER, -1, "Header"},
    {0x06, BINARY_DATA, -1, "Data"}, V(0x07, VERB_END, "End"), V(0x08, VERB_COMMIT, "Commit"),
    V(0x09, VERB_ABORT, "Abort"), V(0x0A, VERB_RESUME, "Resume"), V(0x0B, VERB_PS, "ListPbos"),
    V(0x0C, VERB_START, "StartPbo"), V(0x0D, VERB_STOP, "StopPbo"),
    V(0x0E, VERB_SET, "SetConstant"), V(0x0F, VERB_CONNECT, "ConnectPorts"),
    V(0x10, VERB_DISCONNECT, "DisconnectPorts"), V(0x11, VERB_PONG, "Pong"),
    V(0x12, VERB_MODULES, "Listing"), V(0x13, VERB_ACK, "Ack"), V(0x14, VERB_NAK, "Nak"),
    {0x15, BINARY_BLOCK_ACK, -1, "BlockAck"}, V(0x16, VERB_READ, "ReadPorts"),
    V(0x17, VERB_PBOS, "PboTable"), V(0x18, VERB_VALUES, "PortValues"),
    V(0x19, VERB_RATE, "SetRate"), V(0x1A, VERB_WATCH, "Watch"),
    V(0x1B, VERB_REPORT, "PerformanceReport"), V(0x1C, VERB_BEAT, "Heartbeat"),
    V(0x1D, VERB_EXPORT, "ExportPort"), V(0x1E, VERB_IMPORT, "ImportPort"),
    V(0x1F, VERB_ADVANCE, "Advance"), V(0x101, VERB_CHALLENGE, "Challenge"),
    V(0x102, VERB_AUTH, "Authenticate"), {0x103, BINARY_SIGNATURE, -1, "Signature"},
    V(0x104, VERB_BYE, "EndSession"), V(0x105, VERB_LOGS, "ReadLog"),
    V(0x106, VERB_LOGLINES, "LogLines"), V(0x107, VERB_CLEAR, "ClearPbo"),
    V(0x108, VERB_HOLD, "HoldStart"), V(0x109, VERB_DESCRIBE, "DescribePbo"),
    V(0x10A, VERB_DESCRIPTION, "PboDescription"), V(0x10B, VERB_RESET, "ResetNode"),
};
#undef V
#define TYPE_COUNT (sizeof TYPES / sizeof TYPES[0])

static const struct verb_spec *spec_of(const struct binary_type *type)
{
    return type->kind == BINARY_VERB ? verb_spec((enum verb)type->verb) : &BINARY_ONLY[type->kind];
}

static const struct binary_type *type_by_code(uint16_t code)
{
    for (size_t i = 0; i < TYPE_COUNT; i++) {
        if (TYPES[i].code == code) {
            return &TYPES[i];
        }
    }
    return 0;
}

static const struct binary_type *type_by_verb(enum verb verb)
{
    for (size_t i = 0; i < TYPE_COUNT; i++) {
        if (TYPES[i].kind == BINARY_VERB && TYPES[i].verb == (int8_t)verb) {
            return &TYPES[i];
        }
    }
    return 0;
}

/* Fields. */

static size_t fixed_size(uint8_t kind)
{
    switch (kind) {
    case FIELD_U8: case FIELD_FLAG: return 1;
    case FIELD_U16: case FIELD_BLOCKS: return 2;
    case FIELD_U32: case FIELD_ADDRESS: return 4;
    case FIELD_U64: return 8;
    default: return 0; /* a tail */
    }
}

static uint64_t read_le(const uint8_t *bytes, size_t size)
{
    uint64_t value = 0;
    for (size_t i = size; i > 0; i--) {
        value = value << 8 | bytes[i - 1];
    }
    return value;
}

static void write_le(uint8_t *bytes, uint64_t value, size_t size)
{
    for (size_t i = 0; i < size; i++, value >>= 8) {
        bytes[i] = (uint8_t)value;
    }
}

/* How refusals name a code (layout.code_text) and a type (Layout.title). */
static void add_code(struct text *why, uint16_t code)
{
    text_add(why, code & EXTENDED ? "0x00 0x" : "0x");
    text_add_hex(why, code & 0xFFu, 2);
}

static void add_title(struct text *why, const struct binary_type *type)
{
    text_format(why, "%s (type ", type->name);
    add_code(why, type->code);
    if (type->kind == BINARY_VERB) {
        text_format(why, ", %s", verb_word((enum verb)type->verb));
    }
    text_add_char(why, ')');
}

static void add_field(struct text *why, const struct field_spec *field,
                      const struct binary_type *type)
{
    text_format(why, "%s of ", field->name);
    add_title(why, type);
    text_add(why, ": ");
}

/* Strict UTF-8, as Python's decoder takes it (text_utf8_point). */
static bool utf8_valid(const uint8_t *data, size_t length)
{
    for (size_t i = 0; i < length;) {
        uint32_t used = 1;
        if (data[i] >= 0x80) {
            (void)text_utf8_point(data + i, (uint32_t)(length - i), &used);
        }
        if (!used) {
            return false;
        }
        i += used;
    }
    return true;
}

/* Decoding. */

static bool refuse_type(const uint8_t *raw, size_t length, struct text *why)
{
    text_add(why, "expected a binary message type among ");
    for (size_t i = 0; i < TYPE_COUNT; i++) {
        text_add(why, i ? ", " : "");
        add_code(why, TYPES[i].code);
    }
    static const char HEX[] = "0123456789abcdef";
    text_add(why, ", got ");
    if (raw[0] != 0) {
        text_add(why, "0x");
        text_add_hex(why, raw[0], 2);
        return false;
    }
    text_add(why, "00");
    if (length > 1) {
        text_add_char(why, ' ');
        text_add_char(why, HEX[raw[1] >> 4]);
        text_add_char(why, HEX[raw[1] & 0xFu]);
    }
    return false;
}

static bool check_ok(const struct binary_type *type, const uint8_t *raw, size_t length)
{
    if (type->kind == BINARY_BLOCK_ACK) {
        return length > CRC16_SIZE &&
               crc16_ccitt(raw, length - CRC16_SIZE) == read_le(raw + length - CRC16_SIZE, 2);
    }
    return length > CRC32_SIZE &&
           crc32_update(0, raw, length - CRC32_SIZE) == read_le(raw + length - CRC32_SIZE, 4);
}

static bool refuse_check(const struct binary_type *type, size_t length, struct text *why)
{
    text_add(why, "expected a binary message of type ");
    add_code(why, type->code);
    text_add(why, type->kind == BINARY_BLOCK_ACK
                        ? " ending in a valid CRC-16/CCITT (initial value 0xFFFF), got "
                        : " ending in a valid CRC-32, got ");
    text_format(why, "%U bytes that do not", (uint64_t)length);
    return false;
}

struct body {
    const uint8_t *bytes;
    size_t length;
};

/* The fixed fields, in order; the tail is what follows them. */
static bool decode_fixed(const struct binary_type *type, struct body *body, struct message *m,
                         struct text *why)
{
    const struct verb_spec *spec = spec_of(type);
    size_t size = 0;
    bool tails = false;
    for (int i = 0; i < spec->count; i++) {
        size += fixed_size(spec->fields[i].kind);
        tails |= fixed_size(spec->fields[i].kind) == 0;
    }
    if (body->length < size || (!tails && body->length > size)) {
        text_format(why, "expected %s%U bytes in the body of ", tails ? "at least " : "",
                    (uint64_t)size);
        add_title(why, type);
        text_format(why, ", got %U", (uint64_t)body->length);
        return false;
    }
    for (int i = 0; i < spec->count; i++) {
        const struct field_spec *field = &spec->fields[i];
        size_t bytes = fixed_size(field->kind);
        if (!bytes) {
            continue;
        }
        uint64_t value = read_le(body->bytes, bytes);
        body->bytes += bytes, body->length -= bytes;
        if (field->kind == FIELD_FLAG && value > 1) {
            add_field(why, field, type);
            text_format(why, "expected 0 or 1, got %U", (uint64_t)value);
            return false;
        }
        m->number[i] = field->kind == FIELD_BLOCKS ? value * BLOCK : value;
        m->present[i] = field->kind != FIELD_ADDRESS || value != NO_ADDRESS;
    }
    return true;
}

/* The tail cut into its fields: each but the last after its one-byte length. */
static bool split_tail(const struct binary_type *type, struct body tail, struct message *m,
                       struct text *why)
{
    const struct verb_spec *spec = spec_of(type);
    int last = -1;
    for (int i = 0; i < spec->count; i++) {
        last = fixed_size(spec->fields[i].kind) ? last : i;
    }
    for (int i = 0; i < spec->count; i++) {
        if (fixed_size(spec->fields[i].kind)) {
            continue;
        }
        size_t length = tail.length;
        if (i != last) {
            if (!tail.length || tail.bytes[0] >= tail.length) {
                add_field(why, &spec->fields[i], type);
                text_format(why, "expected a length byte and that many bytes before the next "
                            "field, got %U bytes", (uint64_t)tail.length);
                return false;
            }
            length = tail.bytes[0];
            tail.bytes++, tail.length--;
        }
        m->present[i] = true;
        m->text[i] = (const char *)tail.bytes;
        m->text_length[i] = length;
        tail.bytes += length, tail.length -= length;
    }
    return true;
}

static bool parse_tail(const struct field_spec *field, const struct message *m, int i,
                       const struct binary_type *type, struct text *why)
{
    const uint8_t *data = (const uint8_t *)m->text[i];
    size_t length = m->text_length[i];
    if (field->kind == FIELD_U32_ARRAY && length % 4) {
        add_field(why, field, type);
        text_format(why, "expected 4 bytes per number, got %U bytes", (uint64_t)length);
        return false;
    }
    if (field->kind == FIELD_U32_ARRAY || field->kind == FIELD_PAYLOAD) {
        return true;
    }
    if (!utf8_valid(data, length)) {
        add_field(why, field, type);
        text_add(why, "expected UTF-8 text, got ");
        text_add_bytes_repr(why, data, length < 40 ? length : 40);
        return false;
    }
    if (field->kind == FIELD_LISTING) { /* a listing that is none: refused as Python refuses it */
        struct word_refusal refused;
        if (!listing_check(m->text[i], length, &refused)) {
            add_field(why, field, type);
            word_refusal_show(why, &refused);
            return false;
        }
    }
    for (size_t at = 0; at < length; at++) {
        if (data[at] == 0) { /* this node's names are C strings: "gain\0x" would name gain */
            add_field(why, field, type);
            text_add(why, "expected text without NUL, got ");
            text_add_bytes_repr(why, data, length < 40 ? length : 40);
            return false;
        }
    }
    return true;
}

static bool decode_tails(const struct binary_type *type, struct body tail, struct message *m,
                         struct text *why)
{
    if (!split_tail(type, tail, m, why)) {
        return false;
    }
    const struct verb_spec *spec = spec_of(type);
    for (int i = 0; i < spec->count; i++) {
        if (!fixed_size(spec->fields[i].kind) && !parse_tail(&spec->fields[i], m, i, type, why)) {
            return false;
        }
    }
    return true;
}

bool binary_decode(const uint8_t *raw, size_t length, struct binary_message *decoded,
                   struct text *why)
{
    if (!length) {
        text_add(why, "expected a message, got nothing");
        return false;
    }
    bool extended = raw[0] == 0;
    const struct binary_type *type = 0;
    if (!extended || length >= 2) {
        type = type_by_code(extended ? (uint16_t)(EXTENDED | raw[1]) : raw[0]);
    }
    if (!type) {
        return refuse_type(raw, length, why);
    }
    if (!check_ok(type, raw, length)) {
        return refuse_check(type, length, why);
    }
    size_t prefix = extended ? 2 : 1;
    size_t end = length - (type->kind == BINARY_BLOCK_ACK ? CRC16_SIZE : CRC32_SIZE);
    struct body body = {raw + prefix, end > prefix ? end - prefix : 0};
    *decoded = (struct binary_message){.kind = (enum binary_kind)type->kind};
    struct message *m = &decoded->message;
    m->line = "";
    if (type->kind == BINARY_VERB) {
        m->verb = (enum verb)type->verb;
    }
    return decode_fixed(type, &body, m, why) && decode_tails(type, body, m, why);
}

/* Encoding. */

/* The binary answer being written, straight onto the link as it is made (one at a time): no
 * buffer of a whole message, only its frame's run. */
static struct {
    struct frame_writer frame;
    uint32_t crc;
} out;

static void out_start(void (*send)(const char *bytes, size_t length))
{
    frame_writer_start(&out.frame, send);
    out.crc = 0;
}

static void out_put(const uint8_t *bytes, size_t length)
{
    out.crc = crc32_update(out.crc, bytes, length);
    frame_writer_put(&out.frame, bytes, length);
}

static void out_number(uint64_t value, size_t size)
{
    uint8_t bytes[8];
    write_le(bytes, value, size);
    out_put(bytes, size);
}

/* The CRC-32 of what was put, and the frame's end. */
static void out_end(void)
{
    uint8_t crc[CRC32_SIZE];
    write_le(crc, out.crc, CRC32_SIZE);
    frame_writer_put(&out.frame, crc, CRC32_SIZE);
    frame_writer_end(&out.frame);
}

/* The index of the tail's last field, the one whose length the message's end gives. */
static int last_tail(const struct verb_spec *spec)
{
    int last = -1;
    for (int i = 0; i < spec->count; i++) {
        last = fixed_size(spec->fields[i].kind) ? last : i;
    }
    return last;
}

static size_t tail_length(const struct message *m, int i)
{
    return m->present[i] ? m->text_length[i] : 0;
}

/* Whether `m` has a binary form: each tail field before the last fits its length byte. */
static bool encodable(const struct message *m, const struct verb_spec *spec)
{
    int last = last_tail(spec);
    for (int i = 0; i < last; i++) {
        if (!fixed_size(spec->fields[i].kind) && tail_length(m, i) > MAX_LEADING_WORD) {
            return false;
        }
    }
    return true;
}

/* Send the binary form of an encodable message of `type`, CRC-32 included. */
static void send_encoded(void (*send)(const char *, size_t), const struct binary_type *type,
                         const struct message *m)
{
    const struct verb_spec *spec = spec_of(type);
    out_start(send);
    if (type->code & EXTENDED) {
        out_number(0x00, 1);
    }
    out_number((uint8_t)type->code, 1);
    for (int i = 0; i < spec->count; i++) {
        size_t bytes = fixed_size(spec->fields[i].kind);
        if (bytes) {
            bool absent = spec->fields[i].kind == FIELD_ADDRESS && !m->present[i];
            out_number(absent ? NO_ADDRESS : m->number[i], bytes);
        }
    }
    int last = last_tail(spec);
    for (int i = 0; i < spec->count; i++) {
        if (fixed_size(spec->fields[i].kind)) {
            continue;
        }
        size_t length = tail_length(m, i);
        if (i != last) {
            out_number(length, 1);
        }
        out_put((const uint8_t *)m->text[i], length);
    }
    out_end();
}

/* An answer that could not be written: the refusal `NAK tid 0 RETRY cannot answer: WHY`, as
 * receiver._encoded makes it. */
static void send_cannot_answer(void (*send)(const char *, size_t), uint32_t tid, const char *why)
{
    char text[CANNOT_ANSWER_MAX];
    struct text reason;
    text_start(&reason, text, sizeof text);
    text_format(&reason, "cannot answer: %s", why);
    out_start(send);
    out_number(0x14, 1);
    out_number(tid, 4);
    out_number(0, 4);
    out_number(0, 1); /* RETRY */
    out_put((const uint8_t *)text, reason.length);
    out_end();
}

void binary_send_line(void (*send)(const char *bytes, size_t length), const char *line,
                      size_t length)
{
    struct message answer;
    char reason[200];
    struct text why;
    text_start(&why, reason, sizeof reason);
    if (!message_decode_answer(line, length, &answer, &why)) {
        send_cannot_answer(send, 0, reason);
        return;
    }
    if (answer.record) {
        send_cannot_answer(send, 0, "a record line is no answer");
        return;
    }
    const struct binary_type *type = type_by_verb(answer.verb);
    if (!type || !encodable(&answer, spec_of(type))) {
        send_cannot_answer(send, (uint32_t)answer.number[0], "the answer does not fit a message");
        return;
    }
    send_encoded(send, type, &answer);
}

void binary_send_block_ack(void (*send)(const char *bytes, size_t length), uint32_t tid,
                           uint32_t programmed)
{
    uint32_t blocks = programmed / BLOCK;
    if (programmed % BLOCK || blocks > 0xFFFFu) {
        char reason[120];
        struct text why;
        text_start(&why, reason, sizeof reason);
        text_format(&why, "BlockAck.value: expected a whole number of 256-byte blocks, "
                    "0..16776960, got %U", (uint64_t)programmed);
        send_cannot_answer(send, 0, reason); /* a BlockAck has no tid: 0, as in Python */
        return;
    }
    uint8_t ack[1 + 2 + 2 + CRC16_SIZE] = {0x15};
    write_le(ack + 1, tid & 0xFFFFu, 2);
    write_le(ack + 3, blocks, 2);
    write_le(ack + 5, crc16_ccitt(ack, 5), CRC16_SIZE);
    frame_writer_start(&out.frame, send);
    frame_writer_put(&out.frame, ack, sizeof ack);
    frame_writer_end(&out.frame);
}
