/* kernel_modules.c - modules becoming PBOs and leaving (kernel.h, "Modules"): registration,
 * admission in place of a PBO of the same name, removal whatever the module's methods answer. */
#include "kernel.h"

#include "area.h"
#include "kernel_internal.h"
#include "registrar.h"
#include "sram.h"
#include "svt.h"

static struct pbo *free_slot(void)
{
    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        if (!kernel.pbos[i].used) {
            return &kernel.pbos[i];
        }
    }
    return 0;
}

/* One SRAM block for the PBO's variables and constants (pbo.h). */
static bool allocate_store(struct pbo *pbo, struct text *why)
{
    const uint32_t size = area_packed(&pbo->module, pbo->module.port_count, STORED);
    char owner[48];
    struct text label;

    pbo->store = 0;
    if (size == 0) {
        return true;
    }
    text_start(&label, owner, sizeof owner);
    text_format(&label, "the variables of module %q", pbo->module.name);
    pbo->store = sram_allocate(size, owner, why);
    return pbo->store != 0;
}

int32_t kernel_register_module(uint32_t base, uint32_t size, uint32_t init, bool replacing,
                               uint32_t *slot)
{
    struct pbo *pbo = free_slot();
    struct text why = kernel_message_text();
    int32_t status;

    if (pbo == 0) {
        return kernel_refuse(STATUS_ERR_NO_MEMORY,
                             "the kernel holds %u PBOs, its most: remove one first",
                             KERNEL_MAX_PBOS);
    }
    status = registrar_run(base, size, init, replacing, &pbo->module, &why);
    if (status != STATUS_OK) {
        return status;
    }
    if (!allocate_store(pbo, &why)) {
        return STATUS_ERR_NO_MEMORY;
    }
    pbo->used = true;
    pbo->pending = true;
    *slot = kernel_slot_of(pbo);
    return STATUS_OK;
}

const char *kernel_module_name(uint32_t slot)
{
    return slot < KERNEL_MAX_PBOS && kernel.pbos[slot].used ? kernel.pbos[slot].module.name : "";
}

void kernel_discard(uint32_t slot)
{
    if (slot < KERNEL_MAX_PBOS && kernel.pbos[slot].used && kernel.pbos[slot].pending) {
        sram_free(kernel.pbos[slot].store);
        kernel.pbos[slot].used = false;
    }
}

/* Off and kill whatever the methods answer, then out of the table (Node._retire). */
static void retire(struct pbo *pbo)
{
    struct text ignored = kernel_message_text();

    estimator_forget(pbo);
    while (!(REMOVABLE & STATES(pbo->state))) {
        (void)pbo_control(pbo, pbo->state == STATE_ON ? METHOD_OFF : METHOD_KILL, &ignored);
        ignored = kernel_message_text();
    }
    svt_forget(pbo);
    sram_free(pbo->store);
    pbo->used = false;
    kernel.draws_uw[kernel_slot_of(pbo)] = 0;
    kernel_reorder();
}

bool kernel_valid_rate(const char *name, uint32_t millihertz)
{
    if (millihertz >= KERNEL_MILLIHERTZ_MIN && millihertz <= KERNEL_MILLIHERTZ_MAX) {
        return true;
    }
    kernel_refuse(0,
                  "PBO %q: expected a rate of 10 to 100000000 mHz (0.01 Hz to 100 kHz), got %u mHz",
                  name, millihertz);
    return false;
}

static void admit(struct pbo *pbo, uint32_t millihertz)
{
    const uint32_t slot = kernel_slot_of(pbo);

    pbo->pending = false;
    pbo->serial = ++kernel.serials;
    pbo->state = STATE_NOT_CREATED;
    pbo->executor.area = 0;
    pbo->job = (struct job){millihertz, 0, false, false, 0, 0, 0};
    bytes_zero(&pbo->counters, sizeof pbo->counters);
    performance_clear(&pbo->performance);
    pbo->logged = 0;
    for (uint32_t port = 0; port < ABI_MAX_PORTS; port++) {
        pbo->sources[port] = UNBOUND;
    }
    kernel.draws_uw[slot] = 0;
    kernel.draw_refused[slot] = false;
    kernel_reorder();
}

int kernel_admit(uint32_t slot, uint32_t millihertz)
{
    struct pbo *pbo;
    struct pbo *replaced;

    if (slot >= KERNEL_MAX_PBOS || !kernel.pbos[slot].used || !kernel.pbos[slot].pending) {
        return kernel_refuse(KERNEL_ERR_UNKNOWN, "no module waits in slot %u", slot);
    }
    pbo = &kernel.pbos[slot];
    if (!kernel_valid_rate(pbo->module.name, millihertz)) {
        return KERNEL_ERR_REFUSED;
    }
    replaced = kernel_named(pbo->module.name);
    if (replaced != 0) {
        retire(replaced);
    }
    admit(pbo, millihertz);
    return KERNEL_OK;
}

int kernel_remove(const char *name)
{
    struct pbo *pbo = kernel_find(name);
    if (pbo == 0) {
        return KERNEL_ERR_UNKNOWN;
    }
    retire(pbo);
    return KERNEL_OK;
}
