/* ports.c - the port names of READ and WATCH (ports.h). */
#include "ports.h"

#include "../kernel/kernel.h"
#include "messages.h"

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

static void refuse_name(struct phrase *why, const char *text, size_t start, size_t end)
{
    phrase_add(why, "expected PBO.port names, got ");
    phrase_add_repr(why, text + start, end - start > 60 ? 60 : end - start);
}

bool ports_parse(const char *text, size_t length, struct port_list *ports, struct phrase *why)
{
    size_t at = 0, start, end;
    size_t bad_start = 0, bad_end = 0;
    bool bad = false;

    ports->count = 0;
    while (next_word(text, length, &at, &start, &end)) {
        if (ports->count == PORTS_MAX) {
            phrase_add(why, "expected at most 32 ports, got more");
            return false;
        }
        if (!bad && !ports_is_port(text + start, end - start)) {
            bad = true, bad_start = start, bad_end = end; /* the first bad one is named */
        }
        name_copy(ports->names[ports->count], text + start,
                  end - start < PORT_NAME_MAX ? end - start + 1 : PORT_NAME_MAX + 1);
        if (end - start > PORT_NAME_MAX) {
            ports->names[ports->count][PORT_NAME_MAX - 1] = '?'; /* matches no port */
        }
        ports->count++;
    }
    if (bad || ports->count == 0) {
        if (bad) {
            refuse_name(why, text, bad_start, bad_end);
        } else {
            phrase_add(why, "expected PBO.port names, got none");
        }
        return false;
    }
    return true;
}

bool ports_readable(const struct port_list *ports, struct phrase *why)
{
    for (uint32_t i = 0; i < ports->count; i++) {
        int32_t value;
        if (kernel_read(ports->names[i], &value) != KERNEL_OK) {
            phrase_add(why, kernel_message());
            return false;
        }
    }
    return true;
}

void ports_add_values(const struct port_list *ports, struct phrase *text)
{
    for (uint32_t i = 0; i < ports->count; i++) {
        int32_t value;
        if (kernel_read(ports->names[i], &value) == KERNEL_OK) {
            if (text->length) {
                phrase_add_char(text, ' ');
            }
            phrase_add(text, ports->names[i]);
            phrase_add_char(text, '=');
            if (value < 0) {
                phrase_add_char(text, '-');
                phrase_add_decimal(text, (uint64_t)0 - (uint64_t)(int64_t)value);
            } else {
                phrase_add_decimal(text, (uint64_t)value);
            }
        }
    }
}
