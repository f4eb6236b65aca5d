/*
 * modules.h - what the loader tells the kernel about modules: the one seam between them.
 *
 * The loader owns the flash and the directory; the kernel (firmware/kernel) owns running
 * modules. When a module becomes the node's (a COMMIT, or found intact at boot) the loader calls
 * `node_module_installed` before the directory write that commits it, so the kernel can run its
 * init (record 08) and refuse a module that does not register: the refusal's reason goes back to
 * the host and the old module stays. `node_module_removed` follows `RM`, and a commit undone
 * after all (the directory write failed). Until the kernel implements them, weak defaults accept
 * every module and run nothing (modules_default.c).
 */
#ifndef NODE_MODULES_H
#define NODE_MODULES_H

#include <stdbool.h>
#include <stdint.h>

/* Module `name` (its descriptor's) now lives at `load_address` (`size` bytes, relocated), its
 * init subroutine at `init_address`; it replaces any module of that name. NULL: registered; else
 * why not, a sentence the host is shown ("commit refused: ..."). */
const char *node_module_installed(const char *name, uint32_t load_address, uint32_t size,
                                  uint32_t init_address);

/* Module `name` is gone: stop it and forget it (its flash is erased next). */
void node_module_removed(const char *name);

#define NODE_MODULE_NAME_MAX 16 /* a module's name: the descriptor's 16 bytes at most */

/* The next module installed (committed, or found at boot) and not yet taken, oldest first:
 * its name in `name` (NODE_MODULE_NAME_MAX + 1 bytes) and true, or false when none waits. The
 * main loop takes each once the line that committed it is answered, to start it (or leave it
 * off, held) as firmware-sim listen does. */
bool node_module_arrived(char *name);

/* Bytes of module SRAM free for instance areas (the kernel's allocator), as the PONG line says
 * them: the Python node says its allocator's free bytes there too. */
uint32_t node_sram_free(void);

#endif
