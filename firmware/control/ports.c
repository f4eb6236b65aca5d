/* ports.c - the port names of READ and WATCH, and every request's names (ports.h). */
#include "ports.h"

#include "../kernel/kernel.h"
#include "../protocol/messages.h"

/* Static rather than on the stack of the handlers: START holds its name while the kernel runs
 * a module's method and its traps, on a path that has no 400 bytes to spare. */
static char names[2][PORTS_NAME_KEPT + 1];

static bool holds(const char *text, size_t length, char c)
{
    for (size_t i = 0; i < length; i++) {
        if (text[i] == c) {
            return true;
        }
    }
    return false;
}

const char *ports_name(int slot, const char *text, size_t length)
{
    static const char QUOTES[2] = {'\'', '"'};
    char *name = names[slot];
    size_t kept = length, dot = 0, used;

    while (dot < length && text[dot] != '.') {
        dot++;
    }
    if (length > PORTS_NAME_KEPT) {
        kept = PORTS_NAME_KEPT - 3; /* room for the form the cut drops (below) */
        while (kept > 0 && ((uint8_t)text[kept] & 0xC0u) == 0x80u) {
            kept--; /* a cut goes between characters */
        }
    }
    bytes_copy(name, text, (uint32_t)kept);
    used = kept;
    /* What the cut drops of the name's form, kept past what a refusal shows: the quotes of the
     * PBO part, then its dot, then those of the whole name (Python's repr picks its quotes by
     * the quotes a string holds, and the kernel quotes either), so at most 3 bytes. */
    for (int part = 0; part < 2 && kept < length; part++) {
        for (int q = 0; q < 2; q++) {
            if (!holds(name, used, QUOTES[q]) &&
                holds(text, part == 0 ? dot : length, QUOTES[q])) {
                name[used++] = QUOTES[q];
            }
        }
        if (part == 0 && dot >= kept && dot < length) {
            name[used++] = '.';
        }
    }
    name[used] = '\0';
    return name;
}

bool ports_is_port(const char *text, size_t length)
{
    size_t dots = 0, dot = 0;
    for (size_t i = 0; i < length; i++) {
        if (text[i] == '=') {
            return false;
        }
        if (text[i] == '.' && dots++ == 0) {
            dot = i;
        }
    }
    return dots == 1 && dot > 0 && dot + 1 < length;
}

/* The next blank-separated word of text[*at..length), as Python's split() finds it. */
static bool next_word(const char *text, size_t length, size_t *at, size_t *start, size_t *end)
{
    while (*at < length && ascii_space(text[*at])) {
        (*at)++;
    }
    if (*at == length) {
        return false;
    }
    *start = *at;
    while (*at < length && !ascii_space(text[*at])) {
        (*at)++;
    }
    *end = *at;
    return true;
}

static void refuse_name(struct text *why, const char *text, size_t start, size_t end)
{
    text_format(why, "expected PBO.port names, got %r", text + start,
                (uint32_t)(end - start > 60 ? 60 : end - start));
}

bool ports_parse(const char *text, size_t length, uint32_t most, struct port_list *ports,
                 struct text *why)
{
    size_t at = 0, start, end, count = 0;
    size_t bad_start = 0, bad_end = 0;
    bool bad = false;

    while (next_word(text, length, &at, &start, &end)) {
        if (count++ == most) {
            text_format(why, "expected at most %u ports, got more", most);
            return false;
        }
        if (!bad && !ports_is_port(text + start, end - start)) {
            bad = true, bad_start = start, bad_end = end; /* the first bad one is named */
        }
    }
    if (bad) {
        refuse_name(why, text, bad_start, bad_end);
        return false;
    }
    if (count == 0) {
        text_add(why, "expected PBO.port names, got none");
        return false;
    }
    *ports = (struct port_list){text, length};
    return true;
}

/* The next name, in the request's name buffer 0. */
static bool next_name(const struct port_list *ports, size_t *at, const char **name)
{
    size_t start, end;
    if (!next_word(ports->text, ports->length, at, &start, &end)) {
        return false;
    }
    *name = ports_name(0, ports->text + start, end - start);
    return true;
}

bool ports_readable(const struct port_list *ports, struct text *why)
{
    const char *name;
    for (size_t at = 0; next_name(ports, &at, &name);) {
        int32_t value;
        if (kernel_read(name, &value) != KERNEL_OK) {
            text_add(why, kernel_message());
            return false;
        }
    }
    return true;
}

void ports_add_values(const struct port_list *ports, struct text *text)
{
    const char *name;
    for (size_t at = 0; next_name(ports, &at, &name);) {
        int32_t value;
        if (kernel_read(name, &value) == KERNEL_OK) {
            if (text->length) {
                text_add_char(text, ' ');
            }
            text_format(text, "%s=", name);
            if (value < 0) {
                text_format(text, "-%U", (uint64_t)0 - (uint64_t)(int64_t)value);
            } else {
                text_add_unsigned(text, (uint64_t)value);
            }
        }
    }
}

void ports_keep(struct port_list *ports, char *kept)
{
    struct text names;
    const char *name;
    text_start(&names, kept, PORTS_TEXT_MAX);
    for (size_t at = 0; next_name(ports, &at, &name);) {
        if (names.length) {
            text_add_char(&names, ' ');
        }
        text_add(&names, name);
    }
    *ports = (struct port_list){kept, names.length};
}
