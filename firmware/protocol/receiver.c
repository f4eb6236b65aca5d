/*
 * receiver.c - the hex-mode protocol state machine (receiver.h). Each handler answers one
 * request with the lines hexmigrate/transfer/receiver.py answers it with; the reasons are its
 * words, so the host tells the user the same thing whichever node refused.
 */
#include "receiver.h"

#include "../board/board.h"
#include "../control/control.h"
#include "../loader/hex_record.h"
#include "../loader/loader.h"
#include "../loader/node.h"
#include "binary_messages.h"
#include "messages.h"
#include "session.h"

#define IMPLICIT 0u
#define MAX_IMPLICIT_RELOCATIONS 1024u
#define REASON_MAX 400

struct transfer {
    bool used;
    uint32_t tid;
    uint32_t order; /* when it was opened: record lines go to the newest open one */
    struct load_session session;
    bool has_link_base, announced, sized, header_done, verified;
    uint32_t link_base, relocations, size, acked, base;
    struct loaded_image image;
    uint64_t touched;
};

struct commit_answer {
    uint32_t tid, address;
    char name[DIRECTORY_NAME_LEN + 1];
};

static struct {
    void (*send)(const char *bytes, size_t length);
    struct transfer transfers[MAX_TRANSFERS];
    uint32_t opened;
    struct commit_answer commits[REMEMBERED_COMMITS];
    uint32_t commit_count, commit_next;
    bool binary; /* the message being answered came in binary mode: so do its answers */
} receiver;

/* A fatal refusal: the reason, and the transfer it ends (NULL: none). */
struct refusal {
    char reason[REASON_MAX];
    struct text why;
};

void receiver_init(void (*send)(const char *bytes, size_t length))
{
    for (uint32_t i = 0; i < MAX_TRANSFERS; i++) {
        receiver.transfers[i].used = false; /* a restart forgets transfers: boot frees flash */
    }
    receiver.commit_count = receiver.commit_next = 0;
    receiver.send = send;
    session_reset();
}

bool receiver_answering_binary(void)
{
    return receiver.binary;
}

/* Answers. */

/* Every answer is written once, as hex mode's line; a binary request's answer is that line
 * re-encoded as the binary message of its verb. */
static void send_line(struct text *line)
{
    if (receiver.binary) {
        binary_send_line(receiver.send, line->buffer, line->length);
        return;
    }
    receiver.send(line->buffer, line->length);
}

/* An answer's line, in the node's one (messages.h): no line buffer on the stack, where a
 * request's deepest path (a COMMIT whose module's init traps) needs the room. */
static struct text answer_start(void)
{
    struct text line;
    text_start(&line, answer_line, sizeof answer_line);
    return line;
}

static void ack(uint32_t tid, uint32_t value, const char *text)
{
    struct text line = answer_start();
    reply_ack(&line, tid, value, text);
    send_line(&line);
}

static void nak(uint32_t tid, uint32_t value, bool fatal, const char *reason)
{
    struct text line = answer_start();
    reply_nak(&line, tid, value, fatal, reason);
    send_line(&line);
}

static void start_refusal(struct refusal *refusal)
{
    text_start(&refusal->why, refusal->reason, sizeof refusal->reason);
}

/* Transfers. */

static struct transfer *find_transfer(uint32_t tid)
{
    for (uint32_t i = 0; i < MAX_TRANSFERS; i++) {
        if (receiver.transfers[i].used && receiver.transfers[i].tid == tid) {
            return &receiver.transfers[i];
        }
    }
    return 0;
}

static uint32_t open_count(void)
{
    uint32_t count = 0;
    for (uint32_t i = 0; i < MAX_TRANSFERS; i++) {
        count += receiver.transfers[i].used;
    }
    return count;
}

/* Why BEGIN is refused when MAX_TRANSFERS are open. */
static void refuse_crowded(struct text *why)
{
    text_format(why, "%u transfers are open (an idle one ends after 60 s)", MAX_TRANSFERS);
}

static struct transfer *free_slot(void)
{
    for (uint32_t i = 0; i < MAX_TRANSFERS; i++) {
        if (!receiver.transfers[i].used) {
            return &receiver.transfers[i];
        }
    }
    return 0;
}

/* Erase what a transfer wrote and forget it. */
static void drop(struct transfer *transfer)
{
    if (!transfer || !transfer->used) {
        return;
    }
    if (transfer->verified) {
        loader_discard(&transfer->image);
    } else {
        loader_abort(&transfer->session);
    }
    transfer->used = false;
}

/* A fatal refusal ends the transfer it names (if the node knows it): its flash given back, then
 * the NAK that says why. */
static void refuse_transfer(struct transfer *t, uint32_t tid, const struct refusal *refusal)
{
    drop(t);
    nak(tid, 0, true, refusal->reason);
}

void receiver_expire(void)
{
    uint64_t now = board_time_us();
    for (uint32_t i = 0; i < MAX_TRANSFERS; i++) {
        struct transfer *t = &receiver.transfers[i];
        if (t->used && now - t->touched > TRANSFER_IDLE_US) {
            drop(t);
        }
    }
}

/* The transfer `tid` names, touched; a fatal refusal when there is none. */
static struct transfer *known_transfer(uint32_t tid, struct refusal *refusal)
{
    struct transfer *transfer = find_transfer(tid);
    if (!transfer) {
        text_format(&refusal->why, "unknown transfer %U: send BEGIN first", (uint64_t)tid);
        return 0;
    }
    transfer->touched = board_time_us();
    return transfer;
}

static struct transfer *open_transfer(uint32_t tid)
{
    struct transfer *transfer = free_slot();
    *transfer = (struct transfer){.used = true, .tid = tid, .order = ++receiver.opened,
                                  .touched = board_time_us()};
    return transfer;
}

/* Requests that are not transfers. */

/* noinline: its text is not in dispatch's frame, under every request's handling. */
__attribute__((noinline)) static void handle_ping(void)
{
    char text[200];
    struct text describe;
    text_start(&describe, text, sizeof text);
    node_describe(&describe);
    struct text line = answer_start();
    reply_pong(&line, text);
    send_line(&line);
}

static void handle_list(void)
{
    struct text line = answer_start();
    reply_modules_start(&line);
    for (uint32_t i = 0; i < node_module_count(); i++) {
        const struct directory_entry *entry = &node_module(i)->entry;
        reply_module(&line, entry->name, entry->load_address, entry->size, entry->crc32);
    }
    reply_end(&line);
    send_line(&line);
}

static void handle_remove(const struct message *m)
{
    char name[DIRECTORY_NAME_LEN + 1];
    struct refusal refusal;
    start_refusal(&refusal);
    size_t length = m->text_length[0];
    bool fits = length <= DIRECTORY_NAME_LEN;
    for (size_t i = 0; fits && i < length; i++) {
        name[i] = m->text[0][i];
        fits = name[i] != '\0'; /* a binary name may hold one: it names no module */
    }
    name[fits ? length : 0] = '\0';
    if (!fits || !node_remove(name, &refusal.why)) {
        if (!refusal.why.length) {
            text_format(&refusal.why, "no module named %r", m->text[0], (uint32_t)length);
        }
        nak(0, 0, true, refusal.reason);
        return;
    }
    char said[sizeof "removed " + DIRECTORY_NAME_LEN];
    struct text text;
    text_start(&text, said, sizeof said);
    text_format(&text, "removed %s", name);
    ack(0, 0, said);
}

/* CHALLENGE, AUTH and BYE: session.c answers them. */
static void handle_session(void (*answer)(uint32_t, struct text *), uint32_t tid)
{
    struct text reply = answer_start();
    answer(tid, &reply);
    send_line(&reply);
}

/* A control request on a node without the kernel (the host harness): apart from
 * handle_control, so that its refusal is not on the stack while a request runs. */
__attribute__((noinline)) static void refuse_control(const struct message *m)
{
    char reason[sizeof "DISCONNECT refused: this node takes no control requests"];
    struct text why;
    text_start(&why, reason, sizeof reason);
    text_format(&why, "%s refused: this node takes no control requests", verb_word(m->verb));
    nak((uint32_t)m->number[0], 0, true, reason);
}

static void handle_control(const struct message *m)
{
    struct text reply = answer_start();
    if (node_control(m, &reply)) {
        send_line(&reply);
        return;
    }
    refuse_control(m);
}

/* A transfer. */

static void handle_begin(const struct message *m)
{
    uint32_t tid = (uint32_t)m->number[0], size = (uint32_t)m->number[2];
    uint32_t link_base = (uint32_t)m->number[4];
    struct transfer *existing = find_transfer(tid);
    struct refusal refusal;
    start_refusal(&refusal);
    if (existing) { /* our ACK was lost and the sender asks again */
        ack(tid, loader_load_base(&existing->session), "begun");
        return;
    }
    text_add(&refusal.why, "cannot begin: ");
    if ((uint64_t)link_base + size > 0x100000000ull) {
        text_format(&refusal.why, "an image of %U bytes linked at %a ends past the 32-bit address "
                    "space", (uint64_t)size, (uint32_t)link_base);
        nak(tid, 0, true, refusal.reason);
        return;
    }
    if (open_count() >= MAX_TRANSFERS) {
        refuse_crowded(&refusal.why);
        nak(tid, 0, true, refusal.reason);
        return;
    }
    struct transfer *transfer = open_transfer(tid);
    if (!loader_begin(&transfer->session, tid, true, size, m->present[5], (uint32_t)m->number[5],
                      &refusal.why)) {
        transfer->used = false;
        nak(tid, 0, true, refusal.reason);
        return;
    }
    transfer->has_link_base = transfer->announced = transfer->sized = true;
    transfer->link_base = link_base;
    transfer->relocations = (uint32_t)m->number[3];
    transfer->size = size;
    ack(tid, loader_load_base(&transfer->session), "begun");
}

/* The progress acknowledgement: `ACK tid programmed` in hex mode, the 7-byte BlockAck in
 * binary mode (one per DATA message, once its blocks are programmed). */
static void progress(const struct transfer *transfer)
{
    if (receiver.binary) {
        binary_send_block_ack(receiver.send, transfer->tid, loader_programmed(&transfer->session));
        return;
    }
    ack(transfer->tid, loader_programmed(&transfer->session), "");
}

/* Data at a link address (transfer.py's _feed): in order it is loaded, a repeat acknowledged,
 * a gap refused with the first byte the node lacks. False: a fatal refusal in `refusal`. */
static bool feed(struct transfer *t, uint32_t address, const uint8_t *data, uint32_t length,
                 struct refusal *refusal)
{
    struct load_session *session = &t->session;
    if (!t->has_link_base) {
        t->has_link_base = true;
        t->link_base = address;
    }
    if (!t->header_done && t->announced) {
        loader_rewind(session);
        nak(t->tid, loader_programmed(session), false, "header incomplete: send it again");
        return true;
    }
    uint64_t expected = (uint64_t)t->link_base + loader_received(session);
    if ((uint64_t)address + length <= expected) {
        if (loader_programmed(session) >= loader_received(session)) {
            progress(t);
        } else {
            ack(t->tid, loader_received(session), "repeat");
        }
        return true;
    }
    if (address > expected) {
        char reason[sizeof "expected data at 0x00000000, got 0x00000000"];
        struct text gap;
        text_start(&gap, reason, sizeof reason);
        text_format(&gap, "expected data at %a, got %a", (uint32_t)expected, (uint32_t)address);
        nak(t->tid, loader_received(session), false, reason);
        return true;
    }
    if (t->verified) { /* binary DATA may name it: its flash past the image was given back */
        text_format(&refusal->why, "expected no data after END: transfer %U is verified, send "
                    "COMMIT or ABORT", (uint64_t)t->tid);
        return false;
    }
    uint32_t skip = (uint32_t)(expected - address);
    if (!loader_feed_data(session, (uint32_t)expected, data + skip, length - skip,
                          &refusal->why)) {
        return false;
    }
    if (t->sized && loader_received(session) >= t->size && !loader_flush(session, &refusal->why)) {
        return false;
    }
    if (loader_programmed(session) > t->acked) {
        t->acked = loader_programmed(session);
        progress(t);
    }
    return true;
}

/* The pointer count a header may reach: what BEGIN announced, no more words than the image
 * has, and what the loader keeps. */
static bool relocation_room(const struct transfer *t, uint32_t count, struct refusal *refusal)
{
    uint32_t limit = t->announced ? t->relocations : MAX_IMPLICIT_RELOCATIONS;
    if (t->sized && t->size / 4 < limit) {
        limit = t->size / 4;
    }
    if (limit > LOADER_MAX_RELOCATIONS) {
        limit = LOADER_MAX_RELOCATIONS;
    }
    if (count <= limit) {
        return true;
    }
    text_format(&refusal->why, "expected at most %U pointer locations, got %U", (uint64_t)limit,
                (uint64_t)count);
    return false;
}

static bool pointer_line(struct transfer *t, const struct hex_record *record,
                         struct refusal *refusal)
{
    struct load_session *session = &t->session;
    uint32_t value = hex_record_value(record);
    if (record->type == RECORD_POINTER) {
        if (loader_has_relocation(session, value)) {
            return true;
        }
        return relocation_room(t, session->relocation_count + 1u, refusal) &&
               loader_feed_relocation(session, value, &refusal->why);
    }
    if (!t->header_done) {
        if (!session->has_init && !loader_feed_init(session, value, &refusal->why)) {
            return false;
        }
        uint32_t got = session->relocation_count;
        if (t->announced && got > t->relocations) {
            text_format(&refusal->why, "expected %U pointer records (BEGIN), got %U",
                        (uint64_t)t->relocations, (uint64_t)got);
            return false;
        }
        if (t->announced && got < t->relocations) {
            char reason[sizeof "header incomplete: 4294967295 missing"];
            struct text missing; /* the records that came stay; the lost ones fill in */
            text_start(&missing, reason, sizeof reason);
            text_format(&missing, "header incomplete: %U missing",
                        (uint64_t)(t->relocations - got));
            nak(t->tid, 0, false, reason);
            return true;
        }
        t->header_done = true;
    }
    ack(t->tid, loader_programmed(session), "header"); /* also for a header sent again */
    return true;
}

/* END, or the EOF record (`check` false): the image read back from flash, its CRC-32 checked. */
static bool end_transfer(struct transfer *t, bool check, uint32_t crc, struct refusal *refusal)
{
    if (!t->verified) {
        t->session.ended = true;
        uint32_t before = refusal->why.length;
        text_add(&refusal->why, "not a valid module: ");
        if (!loader_finish(&t->session, &t->image, &refusal->why)) {
            return false;
        }
        text_cut(&refusal->why, before);
        t->verified = true;
    }
    if (check && t->image.crc32 != crc) {
        text_format(&refusal->why, "CRC-32 of the programmed image is %a, expected %a",
                    (uint32_t)t->image.crc32, (uint32_t)crc);
        return false;
    }
    char said[sizeof "verified crc=0x00000000"];
    struct text verified;
    text_start(&verified, said, sizeof said);
    text_format(&verified, "verified crc=%a", (uint32_t)t->image.crc32);
    ack(t->tid, t->image.size, said);
    return true;
}

/* The open transfer record lines go to: the newest not yet verified. */
static struct transfer *newest_open(void)
{
    struct transfer *newest = 0;
    for (uint32_t i = 0; i < MAX_TRANSFERS; i++) {
        struct transfer *t = &receiver.transfers[i];
        if (t->used && !t->verified && (!newest || t->order > newest->order)) {
            newest = t;
        }
    }
    if (newest) {
        newest->touched = board_time_us();
    }
    return newest;
}

/* The transfer of a record line: the open one, or the implicit one of a module typed on a
 * terminal without BEGIN. */
static struct transfer *text_transfer(struct refusal *refusal)
{
    struct transfer *transfer = newest_open();
    if (transfer) {
        return transfer;
    }
    if (find_transfer(IMPLICIT)) {
        text_add(&refusal->why,
                   "a module sent without BEGIN is loading on another connection: send BEGIN");
        return 0;
    }
    if (open_count() >= MAX_TRANSFERS) {
        text_add(&refusal->why, "cannot begin: ");
        refuse_crowded(&refusal->why);
        return 0;
    }
    transfer = open_transfer(IMPLICIT);
    uint32_t before = refusal->why.length;
    text_add(&refusal->why, "cannot begin: ");
    if (!loader_begin(&transfer->session, IMPLICIT, false, 0, false, 0, &refusal->why)) {
        transfer->used = false;
        return 0;
    }
    text_cut(&refusal->why, before);
    return transfer;
}

static bool record_line(struct transfer *t, const struct hex_record *record,
                        struct refusal *refusal)
{
    switch (record->type) {
    case RECORD_DATA:
        return feed(t, t->base + record->address, record->data, record->length, refusal);
    case RECORD_LINEAR:
        t->base = hex_record_value(record) << 16;
        return true;
    case RECORD_SEGMENT:
        t->base = hex_record_value(record) << 4;
        return true;
    case RECORD_POINTER:
    case RECORD_INIT:
        return pointer_line(t, record, refusal);
    case RECORD_SIGNATURE:
        return loader_feed_signature(&t->session, record->address, record->data, record->length,
                                     &refusal->why);
    case RECORD_EOF:
        return end_transfer(t, false, 0, refusal);
    default:
        return true; /* start addresses mean nothing for a module: 08 is its entry */
    }
}

static void handle_record(const struct message *m)
{
    struct hex_record record;
    struct refusal refusal;
    start_refusal(&refusal);
    /* A refusal's words before its reason are written first and taken back when nothing is
     * refused (here, in text_transfer and end_transfer): no second reason on the stack. */
    text_add(&refusal.why, "bad record: ");
    if (!hex_record_decode(m->line, m->line_length, &record, &refusal.why)) {
        struct transfer *open = newest_open(); /* refused before it opens a transfer */
        nak(open ? open->tid : IMPLICIT, open ? loader_received(&open->session) : 0, false,
            refusal.reason);
        return;
    }
    text_cut(&refusal.why, 0);
    struct transfer *transfer = text_transfer(&refusal);
    if (!transfer || !record_line(transfer, &record, &refusal)) {
        drop(transfer);
        nak(IMPLICIT, 0, true, refusal.reason); /* a record line has no tid: 0, as in Python */
    }
}

static void handle_end(uint32_t tid, uint32_t crc)
{
    struct refusal refusal;
    start_refusal(&refusal);
    struct transfer *t = known_transfer(tid, &refusal);
    if (!t || !end_transfer(t, true, crc, &refusal)) {
        refuse_transfer(t, tid, &refusal);
    }
}

static const struct commit_answer *remembered_commit(uint32_t tid)
{
    for (uint32_t i = 0; i < receiver.commit_count; i++) {
        if (receiver.commits[i].tid == tid) {
            return &receiver.commits[i];
        }
    }
    return 0;
}

static void send_installed(const struct commit_answer *answer)
{
    char said[sizeof "installed " + DIRECTORY_NAME_LEN];
    struct text installed;
    text_start(&installed, said, sizeof said);
    text_format(&installed, "installed %s", answer->name);
    ack(answer->tid, answer->address, said);
}

static void remember_commit(const struct commit_answer *answer)
{
    receiver.commits[receiver.commit_next] = *answer;
    receiver.commit_next = (receiver.commit_next + 1) % REMEMBERED_COMMITS;
    if (receiver.commit_count < REMEMBERED_COMMITS) {
        receiver.commit_count++;
    }
}

static void handle_commit(uint32_t tid)
{
    const struct commit_answer *known = remembered_commit(tid);
    if (known) {
        send_installed(known);
        return;
    }
    struct refusal refusal;
    start_refusal(&refusal);
    struct transfer *t = known_transfer(tid, &refusal);
    if (!t) {
        nak(tid, 0, true, refusal.reason);
        return;
    }
    if (!t->verified) {
        nak(tid, loader_programmed(&t->session), false, "not verified: send END first");
        return;
    }
    t->used = false;
    struct commit_answer answer = {tid, 0, {0}};
    text_add(&refusal.why, "commit refused: ");
    if (!node_commit(&t->image, answer.name, &answer.address, &refusal.why)) {
        nak(tid, 0, true, refusal.reason);
        return;
    }
    remember_commit(&answer);
    send_installed(&answer);
}

static void handle_abort(uint32_t tid)
{
    drop(find_transfer(tid));
    ack(tid, 0, "aborted");
}

static void handle_resume(uint32_t tid)
{
    struct refusal refusal;
    start_refusal(&refusal);
    struct transfer *t = known_transfer(tid, &refusal);
    if (!t) {
        nak(tid, 0, true, refusal.reason);
        return;
    }
    const char *state = t->verified ? "verified" : t->header_done ? "header" : "begun";
    loader_rewind(&t->session);
    ack(tid, loader_programmed(&t->session), state);
}

/* Binary mode's HEADER: all pointer words and the init at once (hex mode's 07 and 08 lines),
 * taken once; sent again after a lost answer it is only acknowledged again. */
static bool take_header(struct transfer *t, const struct message *m, struct refusal *refusal)
{
    const uint8_t *words = (const uint8_t *)m->text[BINARY_WORDS];
    uint32_t count = (uint32_t)(m->text_length[BINARY_WORDS] / 4);
    if (!relocation_room(t, count, refusal) || !loader_reset_pointers(&t->session, &refusal->why)) {
        return false;
    }
    for (uint32_t i = 0; i < count; i++, words += 4) {
        uint32_t location = (uint32_t)words[0] | (uint32_t)words[1] << 8 |
                            (uint32_t)words[2] << 16 | (uint32_t)words[3] << 24;
        if (loader_has_relocation(&t->session, location)) {
            text_format(&refusal->why, "line 0: expected each pointer word once, got %a again "
                        "(first on line 0)", (uint32_t)location);
            return false;
        }
        if (!loader_feed_relocation(&t->session, location, &refusal->why)) {
            return false;
        }
    }
    if (!loader_feed_init(&t->session, (uint32_t)m->number[BINARY_INIT], &refusal->why)) {
        return false;
    }
    t->header_done = true;
    return true;
}

static void handle_header(const struct message *m)
{
    uint32_t tid = (uint32_t)m->number[BINARY_TID];
    struct refusal refusal;
    start_refusal(&refusal);
    struct transfer *t = known_transfer(tid, &refusal);
    if (!t || (!t->header_done && !take_header(t, m, &refusal))) {
        refuse_transfer(t, tid, &refusal);
        return;
    }
    ack(tid, loader_programmed(&t->session), "header");
}

/* Binary mode's SIGNATURE: a piece of the signature area (hex mode's 09 lines), acknowledged on
 * its own; the same piece again is taken without complaint, other bytes end the transfer. */
static void handle_signature(const struct message *m)
{
    uint32_t tid = (uint32_t)m->number[BINARY_TID];
    struct refusal refusal;
    start_refusal(&refusal);
    struct transfer *t = known_transfer(tid, &refusal);
    uint32_t offset = (uint32_t)m->number[BINARY_OFFSET];
    uint32_t length = (uint32_t)m->text_length[BINARY_AREA];
    /* A verified transfer's area was taken, and the node's one area may be another's now. */
    bool take = t && !t->verified;
    if (!t || !loader_signature_fits((uint64_t)offset + length, &refusal.why) ||
        (take && !loader_feed_signature(&t->session, offset, (const uint8_t *)m->text[BINARY_AREA],
                                        length, &refusal.why))) {
        refuse_transfer(t, tid, &refusal);
        return;
    }
    ack(tid, loader_programmed(&t->session), "signature");
}

/* Binary mode's DATA: the bytes at a link address, loaded as a record line's are; its blocks
 * are programmed once the whole message is here, then acknowledged with one BlockAck. */
static void handle_data(const struct message *m)
{
    uint32_t tid = (uint32_t)m->number[BINARY_TID];
    struct refusal refusal;
    start_refusal(&refusal);
    struct transfer *t = known_transfer(tid, &refusal);
    const uint8_t *payload = (const uint8_t *)m->text[BINARY_PAYLOAD];
    if (!t || !feed(t, (uint32_t)m->number[BINARY_ADDRESS], payload,
                    (uint32_t)m->text_length[BINARY_PAYLOAD], &refusal)) {
        refuse_transfer(t, tid, &refusal);
    }
}

static void dispatch(const struct message *m)
{
    uint32_t tid = (uint32_t)m->number[0];
    switch (m->verb) {
    case VERB_PING: handle_ping(); break;
    case VERB_LS: handle_list(); break;
    case VERB_RM: handle_remove(m); break;
    case VERB_BEGIN: handle_begin(m); break;
    case VERB_END: handle_end(tid, (uint32_t)m->number[1]); break;
    case VERB_COMMIT: handle_commit(tid); break;
    case VERB_ABORT: handle_abort(tid); break;
    case VERB_RESUME: handle_resume(tid); break;
    case VERB_CHALLENGE: handle_session(session_challenge, tid); break;
    case VERB_AUTH: handle_session(session_authenticate, tid); break;
    case VERB_BYE: handle_session(session_end, tid); break;
    default:
        if (verb_is_request(m->verb)) {
            handle_control(m);
        } /* an answer (ACK, PONG, ...): a node never answers one */
    }
}

/* A line decoded into `message`, or refused as no message: apart from the handlers, so that the
 * refusal's buffer is not on the stack while a request is handled. */
__attribute__((noinline)) static bool decode_line(const char *line, size_t length,
                                                  struct message *message)
{
    struct refusal refusal;
    start_refusal(&refusal);
    text_add(&refusal.why, "bad message: ");
    if (!message_decode(line, length, message, &refusal.why)) {
        nak(0, 0, false, refusal.reason);
        return false;
    }
    return true;
}

/* A binary message decoded, or refused as none: as decode_line. */
__attribute__((noinline)) static bool decode_binary(const uint8_t *raw, size_t length,
                                                    struct binary_message *decoded)
{
    struct refusal refusal;
    start_refusal(&refusal);
    text_add(&refusal.why, "bad message: ");
    if (!binary_decode(raw, length, decoded, &refusal.why)) {
        nak(0, 0, false, refusal.reason);
        return false;
    }
    return true;
}

void receiver_handle_line(const char *line, size_t length)
{
    static struct message message;
    receiver_expire();
    receiver.binary = false;
    if (!decode_line(line, length, &message)) {
        return;
    }
    if (message.record) {
        handle_record(&message);
    } else {
        dispatch(&message);
    }
}

void receiver_handle_binary(const uint8_t *raw, size_t length)
{
    static struct binary_message decoded;
    receiver_expire();
    receiver.binary = true;
    if (!decode_binary(raw, length, &decoded)) {
        return;
    }
    switch (decoded.kind) {
    case BINARY_VERB: dispatch(&decoded.message); break;
    case BINARY_HEADER: handle_header(&decoded.message); break;
    case BINARY_SIGNATURE: handle_signature(&decoded.message); break;
    case BINARY_DATA: handle_data(&decoded.message); break;
    default: break; /* a BlockAck: an answer, never answered */
    }
}
