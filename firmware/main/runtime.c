/* runtime.c - the kernel on this firmware (runtime.h). */
#include "runtime.h"

#include "../board/board.h"
#include "../kernel/guest_memory.h"
#include "../kernel/kernel.h"
#include "../loader/modules.h"
#include "../rv32/trap.h"

#define BATTERY_MJ 3600000u   /* the Python node's 3600 J */
#define BASE_DRAW_UW 50000u   /* and its own 50 mW */

static struct {
    char names[RUNTIME_MAX_HELD][NODE_MODULE_NAME_MAX + 1];
    uint32_t count;
} held;

void runtime_init(void)
{
    struct board_region sram, window, stack;
    const struct kernel_config config = {board_time_us, 0, 0, BATTERY_MJ, BASE_DRAW_UW};

    board_module_memory(&sram, &window, &stack);
    /* On RV32 a guest address is the address itself: the memory is at the base. */
    guest_memory_map(REGION_FLASH, board_flash_base(), board_flash_size(),
                     board_flash_memory());
    guest_memory_map(REGION_SRAM, sram.base, sram.size, sram.memory);
    guest_memory_map(REGION_WINDOW, window.base, window.size, window.memory);
    guest_memory_map(REGION_STACK, stack.base, stack.size, stack.memory);
    kernel_init(&config);
    trap_init();
}

/* Whether module `name` was held; the hold serves once. */
static bool take_hold(const char *name)
{
    for (uint32_t i = 0; i < held.count; i++) {
        if (text_equal(held.names[i], name)) {
            text_copy(held.names[i], held.names[--held.count], NODE_MODULE_NAME_MAX + 1);
            return true;
        }
    }
    return false;
}

static bool in_error(const char *name)
{
    struct kernel_pbo pbo;
    for (uint32_t index = 0; kernel_pbo_at(index, &pbo); index++) {
        if (text_equal(pbo.name, name)) {
            return text_equal(pbo.state, "ERROR");
        }
    }
    return false;
}

/* PboSetup.start for a module that arrived: created, switched on unless held, and left OFF
 * (not in ERROR) when it refuses, so a host can set the constant it lacks and start it. What
 * the refusal said stays in the PBO's last failure and log (LOGS, DESCRIBE). */
static void start_arrived(const char *name)
{
    bool hold = take_hold(name);
    int result = hold || !board_start_modules() ? kernel_spawn(name) : kernel_start(name);
    if (result != KERNEL_OK && in_error(name)) {
        (void)kernel_clear(name);
    }
}

void runtime_step(void)
{
    char name[NODE_MODULE_NAME_MAX + 1];
    while (node_module_arrived(name)) {
        start_arrived(name);
    }
    (void)kernel_run_once();
}

/* -1, 0, 1 as Python orders two names (byte by byte). */
static int compare(const char *a, const char *b)
{
    while (*a && *a == *b) {
        a++, b++;
    }
    return (unsigned char)*a < (unsigned char)*b ? -1 : *a != *b;
}

/* The held names as Python shows sorted(held): ['a', 'b']. */
static void add_held_sorted(struct text *said)
{
    const char *last = 0;
    text_add_char(said, '[');
    for (uint32_t shown = 0; shown < held.count; shown++) {
        const char *next = 0;
        for (uint32_t i = 0; i < held.count; i++) { /* the least name after the last shown */
            const char *candidate = held.names[i];
            if ((last == 0 || compare(candidate, last) > 0) &&
                (next == 0 || compare(candidate, next) < 0)) {
                next = candidate;
            }
        }
        text_format(said, "%s%r", shown ? ", " : "", next,
                    (uint32_t)(text_length(next, NODE_MODULE_NAME_MAX)));
        last = next;
    }
    text_add_char(said, ']');
}

bool runtime_hold(const char *name, struct text *said)
{
    bool known = false;
    for (uint32_t i = 0; i < held.count; i++) {
        known = known || text_equal(held.names[i], name);
    }
    if (!known && held.count >= RUNTIME_MAX_HELD) {
        text_add(said, "expected at most 16 modules held at once, got ");
        add_held_sorted(said);
        text_format(said, " and %r", name, (uint32_t)(text_length(name, 64)));
        return false;
    }
    if (!known && text_length(name, NODE_MODULE_NAME_MAX + 1) <= NODE_MODULE_NAME_MAX) {
        text_copy(held.names[held.count++], name, NODE_MODULE_NAME_MAX + 1);
    } /* a longer name is no module's: nothing to hold, and the answer is the same */
    text_format(said, "holding %s: it stays off when it is installed, for its constants", name);
    return true;
}

void runtime_forget_holds(void)
{
    held.count = 0;
}
