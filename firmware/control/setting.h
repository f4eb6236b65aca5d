/*
 * setting.h - `PBO.port=VALUE` of a SET request, read as firmware_sim/core/port_values.py's
 * `setting` reads it: the port, and the value as Python's int(text, 0) or float(text) takes
 * it. The kernel holds integers only (the module ABI's ports are uint8, int16 and int32), so a
 * float is kept as whether it is whole: a whole one sets like the integer, a fraction is
 * refused with the port's declared type as the Python node refuses it.
 */
#ifndef NODE_SETTING_H
#define NODE_SETTING_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../kernel/text.h"

struct setting {
    const char *port;   /* PBO.port, in the request's name buffer 0 (ports.h's ports_name) */
    bool whole;         /* an integer value (int, or a float with no fraction) */
    bool too_large;     /* whole, but beyond 64 bits: no port holds it */
    int64_t value;      /* when whole and not too large */
    const char *text;   /* VALUE as given, for a refusal */
    size_t text_length;
};

/* Read `text`; false with port_values.py's reason in `why`. */
bool setting_parse(const char *text, size_t length, struct setting *setting, struct text *why);

/* VALUE as Python's repr of the float would show it (trailing zeros dropped). */
void setting_show(const struct setting *setting, struct text *text);

#endif
