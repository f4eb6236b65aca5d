/*
 * registrar.h - REGISTER, while a module's init subroutine runs (firmware_sim/core/guest.py's
 * Registrar and register_module).
 *
 * The loader wrote an image to flash and fixed its pointers; the kernel calls its init
 * subroutine, whose only job is REGISTER with the address of its descriptor. The descriptor must
 * lie inside the image and pass descriptor_accept; the first REGISTER of a call is the one that
 * counts, a second one is refused (STATUS_ERR_EXISTS, "module_init registered twice").
 */
#ifndef KERNEL_REGISTRAR_H
#define KERNEL_REGISTRAR_H

#include <stdbool.h>
#include <stdint.h>

#include "module.h"
#include "text.h"

/* Answer REGISTER for the running init subroutine. */
int32_t registrar_register(uint32_t descriptor);

/*
 * Run the init subroutine at `init` of the image at `base`, `size` bytes long, and keep the
 * module it registers in `module`. `replacing`: a name already registered is free (the new
 * module will replace that PBO), as when a host sends a new version; otherwise (at boot) every
 * name is taken. Returns STATUS_OK, REGISTER's refusal, or STATUS_ERR_INVALID when the
 * subroutine faulted or returned without registering; `why` says which. It holds the outcome
 * so far while the subroutine runs, and is as it was when the module registered.
 */
int32_t registrar_run(uint32_t base, uint32_t size, uint32_t init, bool replacing,
                      struct module *module, struct text *why);

#endif /* KERNEL_REGISTRAR_H */
