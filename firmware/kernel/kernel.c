/*
 * kernel.c - the kernel's tables, its clock, its messages and the lookups by name that the rest
 * of kernel.h's API (kernel_modules.c, kernel_control.c, kernel_observe.c, kernel_run.c) shares.
 * The parts do the work: pbo.c the lifecycle, svt.c the wiring, scheduler.c the grid,
 * services.c the ecalls.
 */
#include "kernel.h"

#include <stdarg.h>

#include "guest_memory.h"
#include "kernel_internal.h"
#include "sram.h"

struct kernel_state kernel;

/* --- Shared with the parts (kernel_internal.h) ---------------------------------------------- */

uint64_t kernel_now_us(void)
{
    return kernel.config.now_us() - kernel.epoch_us;
}

struct pbo *kernel_slot(uint32_t slot)
{
    return &kernel.pbos[slot];
}

uint32_t kernel_slot_of(const struct pbo *pbo)
{
    return (uint32_t)(pbo - kernel.pbos);
}

void kernel_note(const char *text, uint32_t length)
{
    if (kernel.config.note != 0) {
        kernel.config.note(text, length);
    }
}

void kernel_log_line(uint32_t owner, const char *text, uint32_t length)
{
    struct pbo *pbo;

    if (owner == NO_OWNER) {
        kernel_note(text, length);
        return;
    }
    pbo = &kernel.pbos[owner];
    pbo->logged++;
    module_log_append(pbo->serial, pbo->logged, kernel_now_us(), text, length);
}

bool kernel_name_taken(const char *name, bool replacing)
{
    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        const struct pbo *pbo = &kernel.pbos[i];
        if (pbo->used && (pbo->pending || !replacing) && text_equal(pbo->module.name, name)) {
            return true;
        }
    }
    return false;
}

/* --- Starting and messages ---------------------------------------------------------------- */

void kernel_init(const struct kernel_config *config)
{
    const struct guest_region *sram = guest_memory_region(REGION_SRAM);

    kernel.config = *config;
    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        kernel.pbos[i].used = false;
    }
    kernel.serials = 0;
    kernel.epoch_us = config->now_us();
    kernel.message[0] = '\0';
    sram_reset(sram->base, sram->size);
    estimator_reset();
    module_log_reset();
    timekeeping_restart(&kernel.keeping);
    power_reset(&kernel.power, config->energy_mj, config->base_draw_uw);
}

const char *kernel_message(void)
{
    return kernel.message;
}

struct text kernel_message_text(void)
{
    struct text text;
    text_start(&text, kernel.message, sizeof kernel.message);
    return text;
}

/* Say why a call is refused (text_format's conversions); returns `result`. */
int kernel_refuse(int result, const char *format, ...)
{
    struct text why = kernel_message_text();
    va_list arguments;

    va_start(arguments, format);
    text_vformat(&why, format, arguments);
    va_end(arguments);
    return result;
}

/* --- Lookups ------------------------------------------------------------------------------- */

bool kernel_admitted(const struct pbo *pbo)
{
    return pbo->used && !pbo->pending;
}

struct pbo *kernel_named(const char *name)
{
    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        if (kernel_admitted(&kernel.pbos[i]) && text_equal(kernel.pbos[i].module.name, name)) {
            return &kernel.pbos[i];
        }
    }
    return 0;
}

/* The admitted PBO whose name is the smallest above `after` ("" for the first): a sorted walk
 * without a sorted table. */
static const struct pbo *next_by_name(const char *after)
{
    const struct pbo *best = 0;
    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        const struct pbo *pbo = &kernel.pbos[i];
        if (!kernel_admitted(pbo) || !text_less(after, pbo->module.name)) {
            continue;
        }
        if (best == 0 || text_less(pbo->module.name, best->module.name)) {
            best = pbo;
        }
    }
    return best;
}

/* "unknown PBO 'x'; registered: 'a', 'b'" (names sorted, "none" when there are none), of the
 * name's first `length` bytes. */
static void refuse_unknown(const char *name, uint32_t length)
{
    struct text why = kernel_message_text();
    const char *after = "";

    text_format(&why, "unknown PBO %r; registered: ", name, length);
    for (const struct pbo *next = next_by_name(after); next != 0; next = next_by_name(after)) {
        text_format(&why, after[0] != '\0' ? ", %q" : "%q", next->module.name);
        after = next->module.name;
    }
    text_add(&why, after[0] == '\0' ? "none" : "");
}

struct pbo *kernel_find(const char *name)
{
    struct pbo *pbo = kernel_named(name);
    if (pbo == 0) {
        refuse_unknown(name, text_length(name, MESSAGE_TEXT));
    }
    return pbo;
}

/* The PBO and port index of "pbo.port", or NULL with the Python kernel's UnknownPortError. */
struct pbo *kernel_find_port(const char *name, uint32_t *port)
{
    char owner[ABI_NAME_LEN + 2];
    const uint32_t dot = text_find(name, '.');
    struct pbo *pbo;
    struct text why;

    if (name[dot] != '.') {
        kernel_refuse(0, "unknown port %q; expected one of '<pbo>.<port>'", name);
        return 0;
    }
    if (dot >= sizeof owner) { /* longer than any PBO's name: unknown, as the Python kernel says */
        refuse_unknown(name, dot);
        return 0;
    }
    text_copy(owner, name, dot + 1u);
    pbo = kernel_find(owner);
    for (uint32_t i = 0; pbo != 0 && i < pbo->module.port_count; i++) {
        if (text_equal(pbo->module.ports[i].name, name + dot + 1)) {
            *port = i;
            return pbo;
        }
    }
    if (pbo != 0) {
        why = kernel_message_text();
        text_format(&why, "unknown port %q", name);
        for (uint32_t i = 0; i < pbo->module.port_count; i++) {
            text_format(&why, i == 0 ? "; expected one of %q" : ", %q", pbo->module.ports[i].name);
        }
    }
    return 0;
}

int kernel_result_of(int32_t control)
{
    return control == 0 ? KERNEL_OK : control == PBO_METHOD_FAILED ? KERNEL_ERR_FAILED
                                                                   : KERNEL_ERR_REFUSED;
}
