/* registrar.c - REGISTER and the run of an init subroutine (see registrar.h). */
#include "registrar.h"

#include "abi.h"
#include "descriptor.h"
#include "guest_memory.h"
#include "kernel_internal.h"
#include "module_call.h"
#include "services.h"
#include "sram.h"

/* The caller's `why` holds the outcome while the subroutine runs, after the image and the
 * subroutine it names: no buffer of the registrar's own for a REGISTER's refusal. */
static struct {
    struct module *module; /* filled by an accepted REGISTER */
    struct text *why;      /* the caller's, its outcome after `named` characters */
    uint32_t named;
    bool registered;
    bool replacing;
    int32_t status; /* of the last REGISTER */
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

/* `why` emptied back to the image and subroutine, to say the outcome after them. */
static struct text *outcome(void)
{
    text_cut(run.why, run.named);
    return run.why;
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

    text_start(&why, reason, sizeof reason);
    run.status = accept(descriptor, &why);
    if (run.status == STATUS_OK) {
        run.registered = true;
        return STATUS_OK;
    }
    text_format(outcome(), "REGISTER refused (%s): %s", status_name(run.status), reason);
    return run.status;
}

int32_t registrar_run(uint32_t base, uint32_t size, uint32_t init, bool replacing,
                      struct module *module, struct text *why)
{
    const struct call_scope scope = {0, 0, 0, 0, 0};
    const uint32_t start = why->length;
    struct call_outcome called;

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
    text_format(why, "module image at %a, init subroutine at %a: ", base, init);
    run.why = why;
    run.named = why->length;
    text_add(why, "returned without calling REGISTER");
    services_enter(&scope);
    called = module_call(init, 0);
    services_leave();
    if (called.faulted) {
        text_add(outcome(), services_fault());
        return STATUS_ERR_INVALID;
    }
    if (run.registered) {
        text_cut(why, start);
        return STATUS_OK;
    }
    return run.status;
}
