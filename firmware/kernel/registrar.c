/* registrar.c - REGISTER and the run of an init subroutine (see registrar.h). */
#include "registrar.h"

#include "abi.h"
#include "descriptor.h"
#include "guest_memory.h"
#include "kernel_internal.h"
#include "module_call.h"
#include "services.h"
#include "sram.h"

static struct {
    struct module *module; /* filled by an accepted REGISTER */
    bool registered;
    bool replacing;
    int32_t status; /* of the last REGISTER */
    char refusal[FAILURE_TEXT];
} run;

static bool taken(const char *name)
{
    return kernel_name_taken(name, run.replacing);
}

static const char *status_name(int32_t status)
{
    static const char *const names[] = {"OK", "ERR_INVALID", "ERR_ABI", "ERR_NO_MEMORY",
                                        "ERR_EXISTS"};
    return names[-status];
}

static int32_t accept(uint32_t address, struct text *why)
{
    struct module *module = run.module;
    const uint64_t end = (uint64_t)address + ABI_DESCRIPTOR_SIZE;

    if (run.registered) {
        text_format(why, "%q is already registered", module->name);
        return STATUS_ERR_EXISTS;
    }
    if (address - module->image_base >= module->image_size ||
        end > (uint64_t)module->image_base + module->image_size) {
        text_add(why, "expected the 224-byte descriptor inside the ");
        descriptor_describe_image(why, module->image_base, module->image_size);
        text_format(why, ", got it at %a", address);
        return STATUS_ERR_INVALID;
    }
    return descriptor_accept(address, module, taken, sram_largest_free(), why);
}

int32_t registrar_register(uint32_t descriptor)
{
    char reason[FAILURE_TEXT];
    struct text why;
    struct text refusal;

    text_start(&why, reason, sizeof reason);
    run.status = accept(descriptor, &why);
    if (run.status == STATUS_OK) {
        run.registered = true;
        return STATUS_OK;
    }
    text_start(&refusal, run.refusal, sizeof run.refusal);
    text_format(&refusal, "REGISTER refused (%s): %s", status_name(run.status), reason);
    return run.status;
}

int32_t registrar_run(uint32_t base, uint32_t size, uint32_t init, bool replacing,
                      struct module *module, struct text *why)
{
    const struct call_scope scope = {0, 0, 0, 0, 0};
    struct call_outcome outcome;

    if (size == 0 || !guest_readable(base, size)) {
        /* the loader's bug, not the module's: no descriptor can be read there */
        text_format(why, "module image at %a (%u bytes): expected it inside guest-readable memory",
                    base, size);
        return STATUS_ERR_INVALID;
    }
    module->image_base = base;
    module->image_size = size;
    run.module = module;
    run.registered = false;
    run.replacing = replacing;
    run.status = STATUS_ERR_INVALID;
    text_copy(run.refusal, "returned without calling REGISTER", sizeof run.refusal);
    services_enter(&scope);
    outcome = module_call(init, 0);
    services_leave();
    if (!outcome.faulted && run.registered) {
        return STATUS_OK;
    }
    text_format(why, "module image at %a, init subroutine at %a: %s", base, init,
                outcome.faulted ? services_fault() : run.refusal);
    return outcome.faulted ? STATUS_ERR_INVALID : run.status;
}
