/*
 * libc_min.c - the four functions a freestanding C compiler may call on its own.
 *
 * GCC emits calls to memcpy, memset, memmove and memcmp for struct copies and large
 * initialisations even with -ffreestanding (its documented contract), and the firmware links
 * no libc. The host build (firmware/host) takes the C library's instead.
 */
#include <stddef.h>
#include <stdint.h>

#ifndef FIRMWARE_HOST

void *memcpy(void *destination, const void *source, size_t length)
{
    uint8_t *out = destination;
    const uint8_t *in = source;
    for (size_t i = 0; i < length; i++) {
        out[i] = in[i];
    }
    return destination;
}

void *memmove(void *destination, const void *source, size_t length)
{
    uint8_t *out = destination;
    const uint8_t *in = source;
    if (out < in) {
        for (size_t i = 0; i < length; i++) {
            out[i] = in[i];
        }
    } else {
        for (size_t i = length; i > 0; i--) {
            out[i - 1] = in[i - 1];
        }
    }
    return destination;
}

void *memset(void *destination, int value, size_t length)
{
    uint8_t *out = destination;
    for (size_t i = 0; i < length; i++) {
        out[i] = (uint8_t)value;
    }
    return destination;
}

int memcmp(const void *a, const void *b, size_t length)
{
    const uint8_t *x = a;
    const uint8_t *y = b;
    for (size_t i = 0; i < length; i++) {
        if (x[i] != y[i]) {
            return x[i] < y[i] ? -1 : 1;
        }
    }
    return 0;
}

#endif
