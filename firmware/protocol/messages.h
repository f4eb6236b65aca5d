/*
 * messages.h - hex-mode messages: every verb the protocol declares, read from a line and
 * written to one, in the words of hexmigrate/transfer/messages.py.
 *
 * A command is its verb, one word per field, the free-text field last, then ` *XX` (CRC-8 of
 * the line); a person at a terminal may leave the checksum out. The table below declares each
 * verb once with its fields, as messages.py does, and one reader decodes them all: a field that
 * is not what its type takes is refused naming the field, the line and the form, exactly as the
 * Python node refuses it (`NAK 0 0 RETRY bad message: ...`), so the host prints the same error
 * whichever node it talks to. Answers (ACK, PONG, ...) are decoded too (a malformed one is
 * refused like any line) but never answered.
 */
#ifndef NODE_MESSAGES_H
#define NODE_MESSAGES_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../kernel/text.h"

#define MESSAGE_MAX_FIELDS 6
#define ANSWER_MAX 1024 /* a control answer's line: up to 800 characters of text (LOGLINES) */

/* The one buffer the long lines are written in, a control answer's or a watch's push: the node
 * writes them one at a time, from its main loop, and sends each before the next. */
extern char answer_line[ANSWER_MAX];

enum verb {
    VERB_PING, VERB_LS, VERB_RM, VERB_BEGIN, VERB_END, VERB_COMMIT, VERB_ABORT, VERB_RESUME,
    VERB_PS, VERB_START, VERB_STOP, VERB_SET, VERB_CONNECT, VERB_DISCONNECT, VERB_RATE,
    VERB_WATCH, VERB_READ, VERB_EXPORT, VERB_IMPORT, VERB_ADVANCE, VERB_CHALLENGE, VERB_AUTH,
    VERB_BYE, VERB_LOGS, VERB_DESCRIBE, VERB_CLEAR, VERB_RESET, VERB_HOLD,
    VERB_PONG, VERB_MODULES, VERB_ACK, VERB_NAK, VERB_PBOS, VERB_VALUES, VERB_LOGLINES,
    VERB_DESCRIPTION, VERB_REPORT, VERB_BEAT,
    VERB_COUNT
};

enum field_kind { FIELD_U8, FIELD_U16, FIELD_U32, FIELD_U64, FIELD_ADDRESS, FIELD_FLAG,
                  FIELD_WORD, FIELD_REST, FIELD_LISTING };

struct field_spec {
    const char *name;
    uint8_t kind;
};

struct verb_spec {
    const char *word;
    uint8_t count;
    struct field_spec fields[MESSAGE_MAX_FIELDS]; /* in text order: free text last */
};

/* A decoded line: a command (its fields' numbers and words point into the line), or a record
 * line passed as it is. */
struct message {
    bool record;
    enum verb verb;
    const char *line; /* the stripped line */
    size_t line_length;
    bool present[MESSAGE_MAX_FIELDS];
    uint64_t number[MESSAGE_MAX_FIELDS];
    const char *text[MESSAGE_MAX_FIELDS];
    size_t text_length[MESSAGE_MAX_FIELDS];
};

/* Decode one line (without its line end); false with the reason (after "bad message: "). */
bool message_decode(const char *raw, size_t length, struct message *message, struct text *why);
/* The same for an answer line the node wrote, which it sends as a binary message: its text may
 * hold what a binary request carried beyond ASCII (HOLD's name), which binary mode carries back
 * and hex mode never brings. */
bool message_decode_answer(const char *raw, size_t length, struct message *message,
                           struct text *why);

/* True for a request the node answers (not an answer such as ACK or PONG). */
bool verb_is_request(enum verb verb);
const char *verb_word(enum verb verb);

/* Answers, ` *XX` and the line end included, in `line` (answer_line). */
void reply_ack(struct text *line, uint32_t tid, uint32_t value, const char *text);
void reply_nak(struct text *line, uint32_t tid, uint32_t value, bool fatal, const char *reason);
void reply_pong(struct text *line, const char *text);
/* MODULES: the caller adds `name@0xADDRESS:SIZE:0xCRC32` words with reply_module (the CRC-32
 * of the module's bytes in flash, as its directory entry holds it), then reply_end. */
void reply_modules_start(struct text *line);
void reply_module(struct text *line, const char *name, uint32_t address, uint32_t size,
                  uint32_t crc32);
void reply_end(struct text *line);

/* An answer whose fields are numbers and then free text (PBOS, VALUES, LOGLINES, DESCRIPTION,
 * REPORT, BEAT), in `line` (answer_line): `numbers` in the table's order go in, and `text` is
 * started where the free text goes, so the caller writes it straight into the line (no second
 * buffer of a kilobyte), with the room the line's end needs kept free. */
void reply_text_start(struct text *line, enum verb verb, const uint32_t *numbers,
                      struct text *text);
/* The line's end after the free text written in `text`, its ends stripped, as hex mode writes
 * free text (none when it is empty). */
void reply_text_end(struct text *line, const struct text *text);

/* The fields of `verb`, in text order (the binary codec reads them too, binary_messages.c). */
const struct verb_spec *verb_spec(enum verb verb);
/* A field's word refused: found while the line is read, worded once the refusal has named the
 * field (decode's "size of 'BEGIN ...' (the form: ...): " comes first), so that no buffer holds
 * the reason meanwhile. */
enum word_fault { WORD_NOT_A_NUMBER, WORD_NEGATIVE, WORD_TOO_BIG, WORD_NOT_A_MODULE,
                  WORD_NOT_A_FLAG };
struct word_refusal {
    uint8_t fault; /* enum word_fault */
    uint8_t kind;  /* the number field's kind, whose limit WORD_TOO_BIG shows */
    const char *start;
    size_t length;
};
/* The refusal in the Python node's words: "expected 0..65535, got 70000". */
void word_refusal_show(struct text *why, const struct word_refusal *refused);

/* Whether `text` is a listing's NAME@0xADDRESS:SIZE words; false with the word refused. */
bool listing_check(const char *text, size_t length, struct word_refusal *refused);

/* Python's str.isspace() for an ASCII character: what split() and strip() cut at. */
bool ascii_space(char c);

#endif
