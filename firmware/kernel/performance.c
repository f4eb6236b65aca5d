/* performance.c - the latest performance values (see performance.h). */
#include "performance.h"

void performance_clear(struct performance *performance)
{
    performance->count = 0;
    performance->dropped = 0;
}

static struct performance_value *find(struct performance *performance, uint8_t kind,
                                      uint32_t index)
{
    for (uint32_t i = 0; i < performance->count; i++) {
        if (performance->values[i].kind == kind && performance->values[i].index == index) {
            return &performance->values[i];
        }
    }
    return 0;
}

void performance_file(struct performance *performance, uint64_t time_us, uint8_t kind,
                      uint32_t index, int32_t value_milli)
{
    struct performance_value *value = find(performance, kind, index);

    if (value == 0) {
        if (performance->count == PERFORMANCE_VALUES) {
            performance->dropped++;
            return;
        }
        value = &performance->values[performance->count++];
        value->kind = kind;
        value->index = index;
    }
    value->time_us = time_us;
    value->value_milli = value_milli;
}

const struct performance_value *performance_latest(const struct performance *performance,
                                                   uint8_t kind, uint32_t index)
{
    return find((struct performance *)performance, kind, index);
}

/* How many values sort before value `i`. */
static uint32_t rank(const struct performance *performance, uint32_t i)
{
    const struct performance_value *value = &performance->values[i];
    uint32_t before = 0;
    for (uint32_t j = 0; j < performance->count; j++) {
        const struct performance_value *other = &performance->values[j];
        before += other->kind < value->kind ||
                          (other->kind == value->kind && other->index < value->index)
                      ? 1u
                      : 0u;
    }
    return before;
}

const struct performance_value *performance_ranked(const struct performance *performance,
                                                   uint32_t n)
{
    for (uint32_t i = 0; i < performance->count; i++) {
        if (rank(performance, i) == n) {
            return &performance->values[i];
        }
    }
    return 0;
}
