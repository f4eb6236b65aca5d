/*
 * number_word.h - a number word of a command, read as the Python node reads it.
 *
 * The Python node reads every number field with Python's int(text, 0): decimal, 0x hex, 0o
 * octal or 0b binary, an optional sign, underscores between digits, no leading zero on a
 * decimal. A C node that read numbers another way would take commands the other refuses (or the
 * reverse), and the host would see two nodes disagree; so this is that grammar, exactly.
 */
#ifndef NODE_NUMBER_WORD_H
#define NODE_NUMBER_WORD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../kernel/text.h"

struct number_word {
    bool negative;
    bool overflow;  /* the magnitude does not fit 64 bits */
    uint64_t value; /* the magnitude, when it fits */
};

/* Parse `text`; false when it is not a number at all (int(text, 0) raises). */
bool number_word_parse(const char *text, size_t length, struct number_word *number);

/* The number in decimal, as Python prints the int (even one past 64 bits). */
void number_word_show(const char *text, size_t length, const struct number_word *number,
                      struct text *out);

#endif
