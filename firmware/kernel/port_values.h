/*
 * port_values.h - scalar port values as requests carry them (firmware_sim/core/port_values.py):
 * a number is set only when the port's declared type holds it exactly, and a port's bytes read
 * back as a number of its type (uint8, int16, int32, little-endian).
 */
#ifndef KERNEL_PORT_VALUES_H
#define KERNEL_PORT_VALUES_H

#include <stdbool.h>
#include <stdint.h>

#include "module.h"
#include "text.h"

/* Whether `value` fits scalar port `spec` exactly; else `why` names `port`, its type and the
 * value: "gain.k is int32 (a whole number from -2147483648 to 2147483647), got 5000000000". */
bool port_value_exact(const char *port, const struct port_spec *spec, int64_t value,
                      struct text *why);
/* Write a value port_value_exact accepted into the port's buffer at guest address `address`. */
void port_value_store(uint32_t address, uint16_t element_size, int64_t value);
/* The scalar at `address` (0: an unbound input, which reads its zero value). */
int32_t port_value_read(uint32_t address, uint16_t element_size);

#endif /* KERNEL_PORT_VALUES_H */
