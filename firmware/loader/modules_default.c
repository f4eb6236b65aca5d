/*
 * modules_default.c - the kernel seam (modules.h) before the kernel exists: every module is
 * accepted and none runs. Weak, so the kernel's own definitions replace these at link time
 * without a build switch.
 */
#include "modules.h"

#include "../board/board.h"

__attribute__((weak)) const char *node_module_installed(const char *name, uint32_t load_address,
                                                        uint32_t size, uint32_t init_address)
{
    (void)name, (void)load_address, (void)size, (void)init_address;
    return 0;
}

__attribute__((weak)) void node_module_removed(const char *name)
{
    (void)name;
}

__attribute__((weak)) bool node_module_arrived(char *name)
{
    (void)name;
    return false;
}

/* No kernel: all of the board's module SRAM is free. */
__attribute__((weak)) uint32_t node_sram_free(void)
{
    struct board_region sram, window, stack;
    board_module_memory(&sram, &window, &stack);
    return sram.size;
}
