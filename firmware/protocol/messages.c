/*
 * messages.c - the hex-mode message table, its reader and its writers (messages.h).
 */
#include "messages.h"

#include "../lib/crc.h"
#include "number_word.h"

#define U8 FIELD_U8
#define U16 FIELD_U16
#define U32 FIELD_U32
#define U64 FIELD_U64
#define TID {"tid", U32}

char answer_line[ANSWER_MAX];

static const struct verb_spec VERBS[VERB_COUNT] = {
    [VERB_PING] = {"PING", 0, {{0}}},
    [VERB_LS] = {"LS", 0, {{0}}},
    [VERB_RM] = {"RM", 1, {{"name", FIELD_WORD}}},
    [VERB_BEGIN] = {"BEGIN", 6, {TID, {"name", FIELD_WORD}, {"size", U32}, {"relocations", U16},
                                 {"link_base", U32}, {"base", FIELD_ADDRESS}}},
    [VERB_END] = {"END", 2, {TID, {"crc", U32}}},
    [VERB_COMMIT] = {"COMMIT", 1, {TID}},
    [VERB_ABORT] = {"ABORT", 1, {TID}},
    [VERB_RESUME] = {"RESUME", 1, {TID}},
    [VERB_PS] = {"PS", 1, {TID}},
    [VERB_START] = {"START", 2, {TID, {"name", FIELD_WORD}}},
    [VERB_STOP] = {"STOP", 2, {TID, {"name", FIELD_WORD}}},
    [VERB_SET] = {"SET", 2, {TID, {"setting", FIELD_WORD}}},
    [VERB_CONNECT] = {"CONNECT", 2, {TID, {"wire", FIELD_WORD}}},
    [VERB_DISCONNECT] = {"DISCONNECT", 2, {TID, {"wire", FIELD_WORD}}},
    [VERB_RATE] = {"RATE", 3, {TID, {"millihertz", U32}, {"name", FIELD_WORD}}},
    [VERB_WATCH] = {"WATCH", 3, {TID, {"period_ms", U32}, {"ports", FIELD_REST}}},
    [VERB_READ] = {"READ", 2, {TID, {"ports", FIELD_REST}}},
    [VERB_EXPORT] = {"EXPORT", 6, {TID, {"number", U16}, {"rate", U32}, {"source", FIELD_WORD},
                                   {"wire", FIELD_WORD}, {"url", FIELD_WORD}}},
    [VERB_IMPORT] = {"IMPORT", 6, {TID, {"number", U16}, {"rate", U32}, {"sink", FIELD_WORD},
                                   {"wire", FIELD_WORD}, {"url", FIELD_WORD}}},
    [VERB_ADVANCE] = {"ADVANCE", 3, {TID, {"until_us", U64}, {"expect", FIELD_REST}}},
    [VERB_CHALLENGE] = {"CHALLENGE", 1, {TID}},
    [VERB_AUTH] = {"AUTH", 3, {TID, {"key", FIELD_WORD}, {"signature", FIELD_WORD}}},
    [VERB_BYE] = {"BYE", 1, {TID}},
    [VERB_LOGS] = {"LOGS", 3, {TID, {"since", U32}, {"name", FIELD_WORD}}},
    [VERB_DESCRIBE] = {"DESCRIBE", 2, {TID, {"name", FIELD_WORD}}},
    [VERB_CLEAR] = {"CLEAR", 2, {TID, {"name", FIELD_WORD}}},
    [VERB_RESET] = {"RESET", 1, {TID}},
    [VERB_HOLD] = {"HOLD", 2, {TID, {"name", FIELD_WORD}}},
    [VERB_PONG] = {"PONG", 1, {{"text", FIELD_REST}}},
    [VERB_MODULES] = {"MODULES", 1, {{"modules", FIELD_LISTING}}},
    [VERB_ACK] = {"ACK", 3, {TID, {"value", U32}, {"text", FIELD_REST}}},
    [VERB_NAK] = {"NAK", 4, {TID, {"value", U32}, {"fatal", FIELD_FLAG}, {"reason", FIELD_REST}}},
    [VERB_PBOS] = {"PBOS", 2, {TID, {"pbos", FIELD_REST}}},
    [VERB_VALUES] = {"VALUES", 2, {TID, {"values", FIELD_REST}}},
    [VERB_LOGLINES] = {"LOGLINES", 3, {TID, {"latest", U32}, {"lines", FIELD_REST}}},
    [VERB_DESCRIPTION] = {"DESCRIPTION", 2, {TID, {"text", FIELD_REST}}},
    [VERB_REPORT] = {"REPORT", 3, {{"seq", U32}, {"clock_ms", U32}, {"values", FIELD_REST}}},
    [VERB_BEAT] = {"BEAT", 3, {{"seq", U32}, {"clock_ms", U32}, {"state", FIELD_REST}}},
};

bool verb_is_request(enum verb verb)
{
    return verb < VERB_PONG;
}

const char *verb_word(enum verb verb)
{
    return VERBS[verb].word;
}

bool ascii_space(char c)
{
    return c == ' ' || (c >= '\t' && c <= '\r') || (c >= 0x1C && c <= 0x1F);
}

/* A piece of the line: `start` and `length`. */
struct span {
    const char *start;
    size_t length;
};

static struct span strip(struct span s)
{
    while (s.length && ascii_space(s.start[0])) {
        s.start++, s.length--;
    }
    while (s.length && ascii_space(s.start[s.length - 1])) {
        s.length--;
    }
    return s;
}

/* The first word of `rest` and, in `rest`, what follows it without its leading blanks (as
 * Python's split(None, 1)); false when `rest` holds no word. */
static bool next_word(struct span *rest, struct span *word)
{
    struct span s = *rest;
    while (s.length && ascii_space(s.start[0])) {
        s.start++, s.length--;
    }
    if (!s.length) {
        return false;
    }
    size_t n = 0;
    while (n < s.length && !ascii_space(s.start[n])) {
        n++;
    }
    *word = (struct span){s.start, n};
    rest->start = s.start + n;
    rest->length = s.length - n;
    while (rest->length && ascii_space(rest->start[0])) {
        rest->start++, rest->length--;
    }
    return true;
}

static void add_line_repr(struct text *why, const struct message *message, size_t most)
{
    size_t length = message->line_length < most ? message->line_length : most;
    text_add_repr(why, message->line, length);
}

static void add_usage(struct text *why, const struct verb_spec *spec)
{
    text_add(why, spec->word);
    for (int i = 0; i < spec->count; i++) {
        const struct field_spec *field = &spec->fields[i];
        text_add_char(why, ' ');
        if (field->kind == FIELD_FLAG) {
            text_add(why, "RETRY|FATAL");
            continue;
        }
        bool bracket = field->kind == FIELD_ADDRESS || field->kind == FIELD_REST ||
                       field->kind == FIELD_LISTING;
        text_add(why, bracket ? "[" : "");
        for (const char *c = field->name; *c; c++) {
            text_add_char(why, *c >= 'a' && *c <= 'z' ? (char)(*c - 32) : *c);
        }
        text_add(why, bracket ? "]" : "");
    }
}

static uint64_t field_limit(uint8_t kind)
{
    switch (kind) {
    case FIELD_U8: return 0xFF;
    case FIELD_U16: return 0xFFFF;
    case FIELD_U64: return UINT64_MAX;
    case FIELD_ADDRESS: return 0xFFFFFFFEu;
    default: return 0xFFFFFFFFu;
    }
}

/* A word refused as `fault`; false, for the parsers to return. */
static bool refuse_word(struct word_refusal *refused, enum word_fault fault, struct span word,
                        uint8_t kind)
{
    *refused = (struct word_refusal){fault, kind, word.start, word.length};
    return false;
}

void word_refusal_show(struct text *why, const struct word_refusal *refused)
{
    struct number_word number;
    switch (refused->fault) {
    case WORD_NEGATIVE:
        text_add(why, "expected a whole number >= 0, got ");
        break;
    case WORD_TOO_BIG:
        text_format(why, "expected 0..%U, got ", field_limit(refused->kind));
        break;
    default: {
        static const char *const EXPECTED[] = {
            [WORD_NOT_A_NUMBER] = "a number",
            [WORD_NOT_A_MODULE] = "NAME@0xADDRESS:SIZE[:0xCRC32]",
            [WORD_NOT_A_FLAG] = "RETRY or FATAL",
        };
        text_format(why, "expected %s, got %r", EXPECTED[refused->fault], refused->start,
                    (uint32_t)refused->length);
        return;
    }
    }
    number_word_parse(refused->start, refused->length, &number);
    number_word_show(refused->start, refused->length, &number, why);
}

/* A number field's value, refused as fields.py's Number refuses it. */
static bool parse_number(struct span word, uint8_t kind, uint64_t *value,
                         struct word_refusal *refused)
{
    struct number_word number;
    if (!number_word_parse(word.start, word.length, &number)) {
        return refuse_word(refused, WORD_NOT_A_NUMBER, word, kind);
    }
    if (number.negative) {
        return refuse_word(refused, WORD_NEGATIVE, word, kind);
    }
    if (number.overflow || number.value > field_limit(kind)) {
        return refuse_word(refused, WORD_TOO_BIG, word, kind);
    }
    *value = number.value;
    return true;
}

/* Where `c` first occurs in `word` from `from` on, or the word's length. */
static size_t find_from(struct span word, size_t from, char c)
{
    while (from < word.length && word.start[from] != c) {
        from++;
    }
    return from;
}

/* One NAME@0xADDRESS:SIZE word of a listing, or NAME@0xADDRESS:SIZE:0xCRC32. */
static bool parse_module_word(struct span word, struct word_refusal *refused)
{
    size_t at = word.length;
    while (at && word.start[at - 1] != '@') {
        at--;
    }
    size_t colon = find_from(word, at, ':');
    if (at <= 1 || colon >= word.length) {
        return refuse_word(refused, WORD_NOT_A_MODULE, word, FIELD_LISTING);
    }
    size_t second = find_from(word, colon + 1, ':');
    uint64_t ignored;
    struct span address = {word.start + at, colon - at};
    struct span size = {word.start + colon + 1, second - colon - 1};
    if (!parse_number(address, FIELD_U32, &ignored, refused) ||
        !parse_number(size, FIELD_U32, &ignored, refused)) {
        return false;
    }
    if (second == word.length) {
        return true; /* no CRC: a listing from before they carried one */
    }
    struct span crc = {word.start + second + 1, word.length - second - 1};
    return parse_number(crc, FIELD_U32, &ignored, refused);
}

static bool parse_listing(struct span text, struct word_refusal *refused)
{
    struct span word;
    while (next_word(&text, &word)) {
        if (!parse_module_word(word, refused)) {
            return false;
        }
    }
    return true;
}

static bool parse_flag(struct span word, uint64_t *value, struct word_refusal *refused)
{
    static const char *const WORDS[2] = {"RETRY", "FATAL"};
    for (int w = 0; w < 2; w++) {
        size_t n = text_length(WORDS[w], 8);
        bool same = word.length == n;
        for (size_t i = 0; same && i < n; i++) {
            char c = word.start[i];
            same = (c >= 'a' && c <= 'z' ? (char)(c - 32) : c) == WORDS[w][i];
        }
        if (same) {
            *value = (uint64_t)w;
            return true;
        }
    }
    return refuse_word(refused, WORD_NOT_A_FLAG, word, FIELD_FLAG);
}

static bool parse_field(const struct field_spec *field, struct span word, struct message *message,
                        int index, struct word_refusal *refused)
{
    message->present[index] = true;
    message->text[index] = word.start;
    message->text_length[index] = word.length;
    switch (field->kind) {
    case FIELD_WORD: case FIELD_REST: return true;
    case FIELD_LISTING: return parse_listing(word, refused);
    case FIELD_FLAG: return parse_flag(word, &message->number[index], refused);
    default: return parse_number(word, field->kind, &message->number[index], refused);
    }
}

static void usage_error(const struct verb_spec *spec, const struct message *message,
                        struct text *why)
{
    text_add(why, "expected ");
    add_usage(why, spec);
    text_add(why, ", got ");
    add_line_repr(why, message, 60);
}

/* The fields after the verb, one word each, the free text taking what is left. */
static bool decode_fields(const struct verb_spec *spec, struct span rest, struct message *message,
                          struct text *why)
{
    for (int i = 0; i < spec->count; i++) {
        const struct field_spec *field = &spec->fields[i];
        struct span word;
        if (field->kind == FIELD_REST || field->kind == FIELD_LISTING) {
            word = strip(rest);
            rest.length = 0;
        } else if (!next_word(&rest, &word)) {
            if (field->kind == FIELD_ADDRESS) {
                continue; /* left out: no address */
            }
            usage_error(spec, message, why);
            return false;
        }
        struct word_refusal refused;
        if (!parse_field(field, word, message, i, &refused)) {
            text_format(why, "%s of ", field->name);
            add_line_repr(why, message, 60);
            text_add(why, " (the form: ");
            add_usage(why, spec);
            text_add(why, "): ");
            word_refusal_show(why, &refused);
            return false;
        }
    }
    if (strip(rest).length) {
        usage_error(spec, message, why);
        return false;
    }
    return true;
}

static bool hex_pair(const char *s)
{
    for (int i = 0; i < 2; i++) {
        char c = s[i];
        if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F'))) {
            return false;
        }
    }
    return true;
}

/* The line without its ` *XX`, checked; a line with a `*` but no valid checksum at its end is
 * refused (on a noisy line the damage to the checksum may come with damage to the command). */
static bool strip_checksum(const struct message *message, struct span *body, struct text *why)
{
    const char *line = message->line;
    size_t n = message->line_length;
    size_t star = n;
    for (size_t i = n; i >= 2; i--) {
        if (line[i - 2] == ' ' && line[i - 1] == '*') {
            star = i - 2;
            break;
        }
    }
    bool found = star < n && n - (star + 2) == 2 && hex_pair(line + star + 2);
    if (!found) {
        for (size_t i = 0; i < n; i++) {
            if (line[i] == '*') {
                text_format(why, "expected a checksum ' *XX' at the end, got %r",
                            line + (n > 8 ? n - 8 : 0), (uint32_t)(n > 8 ? 8 : n));
                return false;
            }
        }
        *body = (struct span){line, n};
        return true;
    }
    uint8_t sum = crc8_line(line, star);
    uint8_t given = (uint8_t)((line[star + 2] <= '9' ? line[star + 2] - '0'
                                                    : (line[star + 2] | 0x20) - 'a' + 10) << 4 |
                              (line[star + 3] <= '9' ? line[star + 3] - '0'
                                                    : (line[star + 3] | 0x20) - 'a' + 10));
    if (sum != given) {
        text_add(why, "expected checksum ");
        text_add_hex(why, sum, 2);
        text_add(why, ", got ");
        text_add_bytes(why, line + star + 2, 2);
        text_add(why, " in ");
        add_line_repr(why, message, 40);
        return false;
    }
    *body = (struct span){line, star};
    return true;
}

static int find_verb(struct span word)
{
    for (int v = 0; v < VERB_COUNT; v++) {
        const char *w = VERBS[v].word;
        size_t i = 0;
        while (i < word.length && w[i]) {
            char c = word.start[i];
            if ((c >= 'a' && c <= 'z' ? (char)(c - 32) : c) != w[i]) {
                break;
            }
            i++;
        }
        if (i == word.length && !w[i]) {
            return v;
        }
    }
    return -1;
}

bool message_decode(const char *raw, size_t length, struct message *message, struct text *why)
{
    for (size_t i = 0; i < length; i++) {
        if ((uint8_t)raw[i] >= 0x80) {
            text_add(why, "expected an ASCII line");
            return false;
        }
    }
    return message_decode_answer(raw, length, message, why);
}

bool message_decode_answer(const char *raw, size_t length, struct message *message,
                           struct text *why)
{
    struct span line = strip((struct span){raw, length});
    *message = (struct message){.line = line.start, .line_length = line.length};
    if (line.length && line.start[0] == ':') {
        message->record = true;
        return true;
    }
    struct span body, verb;
    if (!strip_checksum(message, &body, why)) {
        return false;
    }
    int found = next_word(&body, &verb) ? find_verb(verb) : -1;
    if (found < 0) {
        text_add(why, "expected a command or a record line, got ");
        add_line_repr(why, message, 30);
        return false;
    }
    message->verb = (enum verb)found;
    return decode_fields(&VERBS[found], body, message, why);
}

/* Writers. Each ends the line with its CRC-8 and a line end. */

void reply_end(struct text *line)
{
    static const char HEX[] = "0123456789ABCDEF";
    uint8_t sum = crc8_line(line->buffer, line->length);
    text_add(line, " *");
    text_add_char(line, HEX[sum >> 4]);
    text_add_char(line, HEX[sum & 0xFu]);
    text_add_char(line, '\n');
}

/* Free text as hex mode writes it: its ends stripped, left out when empty. */
static void add_free_text(struct text *line, const char *text)
{
    struct span s = strip((struct span){text, text_length(text, ANSWER_MAX)});
    if (s.length) {
        text_add_char(line, ' ');
        text_add_bytes(line, s.start, s.length);
    }
}

void reply_ack(struct text *line, uint32_t tid, uint32_t value, const char *text)
{
    text_format(line, "ACK %U %U", (uint64_t)tid, (uint64_t)value);
    add_free_text(line, text);
    reply_end(line);
}

void reply_nak(struct text *line, uint32_t tid, uint32_t value, bool fatal, const char *reason)
{
    text_format(line, "NAK %U %U%s", (uint64_t)tid, (uint64_t)value, fatal ? " FATAL" : " RETRY");
    add_free_text(line, reason);
    reply_end(line);
}

void reply_pong(struct text *line, const char *text)
{
    text_add(line, "PONG");
    add_free_text(line, text);
    reply_end(line);
}

void reply_modules_start(struct text *line)
{
    text_add(line, "MODULES");
}

void reply_module(struct text *line, const char *name, uint32_t address, uint32_t size,
                  uint32_t crc32)
{
    text_format(line, " %s@%a:%U:%a", name, address, (uint64_t)size, crc32);
}

void reply_text_start(struct text *line, enum verb verb, const uint32_t *numbers,
                      struct text *text)
{
    const struct verb_spec *spec = &VERBS[verb];
    text_add(line, spec->word);
    for (int i = 0; i < spec->count; i++) {
        if (spec->fields[i].kind != FIELD_REST) {
            text_format(line, " %U", (uint64_t)(*numbers++));
        }
    }
    size_t at = line->length + 1; /* after the blank before the text */
    size_t end = sizeof " *XX\n" - 1;
    size_t room = line->capacity > at + end ? line->capacity - at - end : 0;
    text_start(text, line->buffer + at, room);
}

void reply_text_end(struct text *line, const struct text *text)
{
    struct span s = strip((struct span){text->buffer, text->length});
    if (s.length) {
        line->buffer[line->length++] = ' ';
        for (size_t i = 0; i < s.length; i++) { /* moves left, over the stripped blanks */
            line->buffer[line->length++] = s.start[i];
        }
        line->buffer[line->length] = '\0';
    }
    reply_end(line);
}

const struct verb_spec *verb_spec(enum verb verb)
{
    return &VERBS[verb];
}

bool listing_check(const char *text, size_t length, struct word_refusal *refused)
{
    return parse_listing((struct span){text, length}, refused);
}
