/*
 * ports.h - the PBO.port names of a READ or a WATCH (hexmigrate/transfer/control.py's
 * `ports`), and their values as `NAME=VALUE` words; the names of every request, kept as far as
 * a refusal shows them.
 */
#ifndef NODE_PORTS_H
#define NODE_PORTS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../capacities/capacities.h" /* WATCH_PORTS_MAX */
#include "../kernel/text.h"

#define PORTS_MAX 32u     /* a READ's: control.py's MAX_PORTS */
#define PORT_NAME_MAX 29  /* a port's full name: a PBO's 16 characters, the dot, a port's 12 */
/* ports_keep's names (a WATCH's), a blank apart. */
#define PORTS_TEXT_MAX (WATCH_PORTS_MAX * (PORT_NAME_MAX + 1))
/* The bytes of a request's name kept: a refusal is cut at 200 characters (receiver.py's
 * MAX_REFUSAL), and before a name it quotes come its verb and words, so no more of it shows. */
#define PORTS_NAME_KEPT 200

/* The names as the request gave them, blank-separated words that ports_parse checked: read
 * where they are, so a READ copies none (a copy of 32 names would take 1 KiB of RAM). */
struct port_list {
    const char *text;
    size_t length;
};

/* The request's name `text`, `length` bytes, as a string in the request's name buffer `slot`
 * (0 or 1: CONNECT's source and sink are the most names alive at once; a later call with the
 * same slot replaces it). A longer name is cut at PORTS_NAME_KEPT bytes, between characters
 * (binary mode carries UTF-8 back as it came): it names no PBO or port then, and a refusal
 * shows no more of it. What the cut would drop of its form stays: its first dot, so that the
 * kernel still reads PBO.port and refuses the PBO as the Python node does, and its quotes,
 * by which a refusal quotes it. */
const char *ports_name(int slot, const char *text, size_t length);

/* True when `text` is `PBO.port` (one dot, a name on each side, no `=`). */
bool ports_is_port(const char *text, size_t length);

/* The names of `text`, refused as control.py refuses them (none, more than `most`: PORTS_MAX
 * for a READ, WATCH_PORTS_MAX for a WATCH; one that is not PBO.port); a name longer than any
 * port's is refused as unknown (ports_readable). */
bool ports_parse(const char *text, size_t length, uint32_t most, struct port_list *ports,
                 struct text *why);

/* Whether every port reads; else false with the kernel's reason. */
bool ports_readable(const struct port_list *ports, struct text *why);

/* ` NAME=VALUE` of each port that reads (a port gone with its module is left out). */
void ports_add_values(const struct port_list *ports, struct text *text);

/* Copy readable names (each PORT_NAME_MAX at most, WATCH_PORTS_MAX of them at most) a blank
 * apart into `kept`, PORTS_TEXT_MAX bytes, and point `ports` there: a WATCH's outlive its
 * request's line. */
void ports_keep(struct port_list *ports, char *kept);

#endif
