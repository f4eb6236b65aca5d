/* performance.c - the latest performance values (see performance.h). */
#include "performance.h"

#include "abi.h"

_Static_assert(PERFORMANCE_VALUES <= 8u, "a bit of `non_functional` per value");
_Static_assert(PERFORMANCE_FUNCTIONAL == 0 && PERFORMANCE_NON_FUNCTIONAL == 1, "a bit per kind");

void performance_clear(struct performance *performance)
{
    performance->count = 0;
    performance->dropped = 0;
    performance->non_functional = 0;
}

static uint8_t kind_of(const struct performance *performance, uint32_t i)
{
    return (uint8_t)((performance->non_functional >> i) & 1u);
}

static struct performance_value *find(struct performance *performance, uint8_t kind,
                                      uint32_t index)
{
    for (uint32_t i = 0; i < performance->count; i++) {
        if (kind_of(performance, i) == kind && performance->values[i].index == index) {
            return &performance->values[i];
        }
    }
    return 0;
}

void performance_file(struct performance *performance, uint8_t kind, uint32_t index,
                      int32_t value_milli)
{
    struct performance_value *value = find(performance, kind, index);

    if (value == 0) {
        if (performance->count == PERFORMANCE_VALUES) {
            performance->dropped++;
            return;
        }
        performance->non_functional |= (uint8_t)(kind << performance->count);
        value = &performance->values[performance->count++];
        value->index = index;
    }
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
    const uint8_t kind = kind_of(performance, i);
    const uint32_t index = performance->values[i].index;
    uint32_t before = 0;
    for (uint32_t j = 0; j < performance->count; j++) {
        const uint8_t other_kind = kind_of(performance, j);
        const uint32_t other_index = performance->values[j].index;
        before += other_kind < kind || (other_kind == kind && other_index < index) ? 1u : 0u;
    }
    return before;
}

bool performance_ranked(const struct performance *performance, uint32_t n, uint8_t *kind,
                        uint32_t *index, int32_t *value_milli)
{
    for (uint32_t i = 0; i < performance->count; i++) {
        if (rank(performance, i) == n) {
            *kind = kind_of(performance, i);
            *index = performance->values[i].index;
            *value_milli = performance->values[i].value_milli;
            return true;
        }
    }
    return false;
}
