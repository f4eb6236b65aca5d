/* instance.c - an instance's area and its method calls (see instance.h). */
#include "instance.h"

#include "area.h"
#include "guest_memory.h"
#include "kernel_internal.h"
#include "module_call.h"
#include "services.h"
#include "sram.h"

static void add_label(struct text *label, const struct module *module, uint8_t role)
{
    text_format(label, "module %q at %a (%s)", module->name, module->image_base,
                role == ROLE_EXECUTOR ? "executor" : "estimator");
}

bool instance_create(struct instance *instance, const struct module *module, enum role role,
                     struct text *why)
{
    char owner[64];
    struct text label;

    text_start(&label, owner, sizeof owner);
    add_label(&label, module, (uint8_t)role);
    instance->area = sram_allocate(module->area_size, owner, why);
    instance->role = (uint8_t)role;
    if (instance->area == 0) {
        return false;
    }
    area_write_context(module, instance->area);
    return true;
}

void instance_release(struct instance *instance)
{
    if (instance->area != 0) {
        sram_free(instance->area);
        instance->area = 0;
    }
}

void instance_put(const struct instance *instance, const struct module *module, uint32_t port,
                  uint32_t value)
{
    guest_copy(instance->area + area_port(module, port), value, port_size(&module->ports[port]));
}

void instance_get(const struct instance *instance, const struct module *module, uint32_t port,
                  uint32_t value)
{
    guest_copy(value, instance->area + area_port(module, port), port_size(&module->ports[port]));
}

void instance_zero(const struct instance *instance, const struct module *module, uint32_t port)
{
    const uint32_t size = port_size(&module->ports[port]);
    bytes_zero(guest_bytes(instance->area + area_port(module, port), size), size);
}

/* The area's place in the task window during a call: its end. */
static uint32_t window_of(const struct module *module)
{
    const struct guest_region *window = guest_memory_region(REGION_WINDOW);
    return window->base + window->size - module->area_size;
}

static void fill_fault(struct call_result *result, const char *label, enum method method)
{
    struct text fault;
    text_start(&fault, result->fault, sizeof result->fault);
    text_format(&fault, "%s, %s: %s", label, method_name(method), services_fault());
}

void instance_call(const struct instance *instance, const struct module *module, uint32_t owner,
                   struct performance *performance, enum method method,
                   struct call_result *result)
{
    const uint32_t entry = module->methods[method];
    const uint32_t window = window_of(module);
    const uint32_t body = module->area_size - ABI_CONTEXT_SIZE;
    const uint64_t start = kernel_now_us();
    char label_buffer[64];
    struct text label;
    struct call_scope scope;
    struct call_outcome outcome;

    result->status = 0;
    result->faulted = false;
    result->duration_us = 0;
    result->fault[0] = '\0';
    if (entry == 0) {
        return; /* an absent method returns PBO_OK at once */
    }
    text_start(&label, label_buffer, sizeof label_buffer);
    add_label(&label, module, instance->role);
    scope = (struct call_scope){module, owner, performance, window, label_buffer};
    /* a fresh context every call: the guest may have overwritten its own in the window */
    area_write_context(module, window);
    guest_copy(window + ABI_CONTEXT_SIZE, instance->area + ABI_CONTEXT_SIZE, body);
    services_enter(&scope);
    outcome = module_call(entry, window);
    services_leave();
    guest_copy(instance->area + ABI_CONTEXT_SIZE, window + ABI_CONTEXT_SIZE, body);
    result->duration_us = kernel_now_us() - start;
    result->status = outcome.status;
    /* a refused service faults the call even if the board's trap handler did not abort it */
    result->faulted = outcome.faulted || services_faulted();
    if (result->faulted) {
        fill_fault(result, label_buffer, method);
    }
}
