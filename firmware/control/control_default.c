/*
 * control_default.c - no kernel, no control: every request is refused by the receiver. Weak,
 * so the kernel's `node_control` replaces it at link time.
 */
#include "control.h"

__attribute__((weak)) bool node_control(const struct message *request, struct text *reply)
{
    (void)request, (void)reply;
    return false;
}
