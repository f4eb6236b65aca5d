/* port_values.c - scalar values of ports (see port_values.h). */
#include "port_values.h"

#include "guest_memory.h"

static const char *type_name(uint16_t element_size)
{
    return element_size == 1 ? "uint8" : element_size == 2 ? "int16" : "int32";
}

bool port_value_exact(const char *port, const struct port_spec *spec, int64_t value,
                      struct text *why)
{
    const int64_t low = spec->element_size == 1 ? 0
                        : spec->element_size == 2 ? -32768
                                                  : -2147483648LL;
    const int64_t high = spec->element_size == 1 ? 255
                         : spec->element_size == 2 ? 32767
                                                   : 2147483647LL;

    if (spec->kind == KIND_SCALAR && value >= low && value <= high) {
        return true;
    }
    if (spec->kind != KIND_SCALAR) {
        text_format(why, "%s is a %s of %s; a value sets only a scalar port, got %D", port,
                    spec->kind == KIND_VECTOR ? "vector" : "frame", type_name(spec->element_size),
                    value);
    } else {
        text_format(why, "%s is %s (a whole number from %D to %D), got %D", port,
                    type_name(spec->element_size), low, high, value);
    }
    return false;
}

void port_value_store(uint32_t address, uint16_t element_size, int64_t value)
{
    uint8_t *bytes = guest_bytes(address, element_size);
    const uint32_t word = (uint32_t)value; /* it fits: a 64-bit shift would need libgcc */
    for (uint32_t i = 0; i < element_size; i++) {
        bytes[i] = (uint8_t)(word >> (8u * i));
    }
}

int32_t port_value_read(uint32_t address, uint16_t element_size)
{
    if (address == 0) {
        return 0;
    }
    if (element_size == 1) {
        return guest_read8(address);
    }
    if (element_size == 2) {
        return (int16_t)guest_read16(address);
    }
    return (int32_t)guest_read32(address);
}
