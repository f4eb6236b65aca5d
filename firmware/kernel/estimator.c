/* estimator.c - a shadow run of one PBO's estimator (see estimator.h). */
#include "estimator.h"

#include "area.h"
#include "guest_memory.h"
#include "kernel.h"
#include "kernel_internal.h"
#include "port_values.h"
#include "sram.h"
#include "svt.h"

static struct {
    struct pbo *pbo; /* NULL: no run open */
    struct instance instance;
    struct performance performance;
    uint32_t inputs;       /* SRAM block: each IN port's value, as of the run's start or given */
    uint32_t outputs;      /* SRAM block: each OUT port's value after the last good step */
    bool started;          /* init ran */
    bool initialized;      /* and worked: kill at close */
    uint32_t steps;        /* estimates that worked */
    char failure[FAILURE_TEXT];
} run;

/* Both blocks hold every port's buffer, at the same offsets. */
static uint32_t offset_of(uint32_t port)
{
    return area_packed(&run.pbo->module, port, ALL_DIRECTIONS);
}

static uint32_t input_of(uint32_t port)
{
    return run.inputs + offset_of(port);
}

static uint32_t output_of(uint32_t port)
{
    return run.outputs + offset_of(port);
}

/* One block for the inputs and one for the outputs, with the same offsets. */
static bool allocate_blocks(const struct module *module, struct text *why)
{
    const uint32_t size = area_packed(module, module->port_count, ALL_DIRECTIONS);

    run.inputs = size != 0 ? sram_allocate(size, "a shadow run's inputs", why) : 0;
    run.outputs = run.inputs != 0 ? sram_allocate(size, "a shadow run's outputs", why) : 0;
    return size == 0 || run.outputs != 0;
}

static void release(void)
{
    instance_release(&run.instance);
    sram_free(run.inputs);
    sram_free(run.outputs);
    run.inputs = 0;
    run.outputs = 0;
    run.pbo = 0;
}

/* Constants into the instance, a snapshot of each wired input into the inputs block. */
static void take_settings(struct pbo *pbo)
{
    const struct module *module = &pbo->module;

    for (uint32_t port = 0; port < module->port_count; port++) {
        const uint32_t size = port_size(&module->ports[port]);
        const uint32_t live = svt_value(pbo, port);
        if (module->ports[port].direction == DIRECTION_IN) {
            if (live != 0) {
                guest_copy(input_of(port), live, size);
            }
        } else if (module->ports[port].direction != DIRECTION_OUT) {
            instance_put(&run.instance, module, port, live);
        }
    }
}

int kernel_estimate_open(const char *name)
{
    struct pbo *pbo = kernel_find(name);
    char reason[160];
    struct text why;

    if (pbo == 0) {
        return KERNEL_ERR_UNKNOWN;
    }
    if (pbo->module.methods[METHOD_ESTIMATE] == 0) {
        return kernel_refuse(KERNEL_ERR_REFUSED, "module %q has no estimate method; only E-PBOs "
                                                 "can run in a shadow run",
                             name);
    }
    if (run.pbo != 0) {
        return kernel_refuse(KERNEL_ERR_REFUSED, "a shadow run of %q is open; close it first",
                             run.pbo->module.name);
    }
    text_start(&why, reason, sizeof reason);
    if (!instance_create(&run.instance, &pbo->module, ROLE_ESTIMATOR, &why) ||
        !allocate_blocks(&pbo->module, &why)) {
        release();
        return kernel_refuse(KERNEL_ERR_REFUSED, "%s", reason);
    }
    run.pbo = pbo;
    run.started = false;
    run.initialized = false;
    run.steps = 0;
    run.failure[0] = '\0';
    performance_clear(&run.performance);
    take_settings(pbo);
    return KERNEL_OK;
}

static struct pbo *open_port(const char *name, uint32_t *port)
{
    struct pbo *pbo;

    if (run.pbo == 0) {
        kernel_refuse(0, "no shadow run is open");
        return 0;
    }
    pbo = kernel_find_port(name, port);
    if (pbo != 0 && pbo != run.pbo) {
        kernel_refuse(0, "unknown port %q; the shadow run is of %q", name, run.pbo->module.name);
        return 0;
    }
    return pbo;
}

int kernel_estimate_give(const char *name, int64_t value)
{
    uint32_t port;
    const struct pbo *pbo = open_port(name, &port);
    const struct port_spec *spec;
    char reason[160];
    struct text why;

    if (pbo == 0) {
        return KERNEL_ERR_REFUSED;
    }
    spec = &pbo->module.ports[port];
    if (spec->direction == DIRECTION_OUT) {
        return kernel_refuse(KERNEL_ERR_REFUSED, "port %q is an out port; values are given to "
                                                 "in, const and resource ports",
                             name);
    }
    if (run.started) {
        return kernel_refuse(KERNEL_ERR_REFUSED, "the shadow run of %q has started: give values "
                                                 "before its first step",
                             pbo->module.name);
    }
    text_start(&why, reason, sizeof reason);
    if (!port_value_exact(name, spec, value, &why)) {
        return kernel_refuse(KERNEL_ERR_REFUSED, "%s", reason);
    }
    if (spec->direction == DIRECTION_IN) {
        port_value_store(input_of(port), spec->element_size, value);
    } else {
        port_value_store(run.instance.area + area_port(&pbo->module, port), spec->element_size,
                         value);
    }
    return KERNEL_OK;
}

/* Record the first failure: the estimator is not run again after it. */
static bool check(enum method method, const struct call_result *result)
{
    struct text failure;

    if (!result->faulted && result->status == 0) {
        return true;
    }
    text_start(&failure, run.failure, sizeof run.failure);
    if (result->faulted) {
        text_format(&failure, "%s faulted: %s", method_name(method), result->fault);
    } else {
        text_format(&failure, "%s returned %d", method_name(method), result->status);
    }
    if (method == METHOD_ESTIMATE) {
        text_format(&failure, " at step %u", run.steps + 1u);
    }
    return false;
}

static void call(enum method method, struct call_result *result)
{
    instance_call(&run.instance, &run.pbo->module, NO_OWNER, &run.performance, method, result);
}

/* One estimate on the run's inputs; its outputs count only if it worked. */
static void step(void)
{
    const struct module *module = &run.pbo->module;
    struct call_result result;

    for (uint32_t port = 0; port < module->port_count; port++) {
        if (module->ports[port].direction == DIRECTION_IN) {
            instance_put(&run.instance, module, port, input_of(port));
        }
    }
    call(METHOD_ESTIMATE, &result);
    if (!check(METHOD_ESTIMATE, &result)) {
        return;
    }
    run.steps++;
    for (uint32_t port = 0; port < module->port_count; port++) {
        if (module->ports[port].direction == DIRECTION_OUT) {
            instance_get(&run.instance, module, port, output_of(port));
        }
    }
}

int kernel_estimate_run(uint32_t steps, uint32_t *done)
{
    struct call_result result;

    if (run.pbo == 0) {
        return kernel_refuse(KERNEL_ERR_REFUSED, "no shadow run is open");
    }
    if (!run.started) {
        run.started = true;
        call(METHOD_INIT, &result);
        run.initialized = check(METHOD_INIT, &result);
    }
    for (uint32_t i = 0; i < steps && run.failure[0] == '\0'; i++) {
        step();
    }
    *done = run.steps;
    return KERNEL_OK;
}

int kernel_estimate_read(const char *name, int32_t *value)
{
    uint32_t port;
    const struct pbo *pbo = open_port(name, &port);
    const struct port_spec *spec;
    uint32_t address;

    if (pbo == 0) {
        return KERNEL_ERR_REFUSED;
    }
    spec = &pbo->module.ports[port];
    if (spec->kind != KIND_SCALAR) {
        return kernel_refuse(KERNEL_ERR_REFUSED, "%s is a %s; only scalar ports are read", name,
                             spec->kind == KIND_VECTOR ? "vector" : "frame");
    }
    address = run.instance.area + area_port(&pbo->module, port); /* a constant: in the instance */
    if (spec->direction == DIRECTION_IN || spec->direction == DIRECTION_OUT) {
        address = spec->direction == DIRECTION_IN ? input_of(port) : output_of(port);
    }
    *value = port_value_read(address, spec->element_size);
    return KERNEL_OK;
}

bool kernel_estimate_performance_at(uint32_t n, uint8_t *kind, uint32_t *index,
                                    int32_t *value_milli)
{
    return run.pbo != 0 && performance_ranked(&run.performance, n, kind, index, value_milli);
}

const char *kernel_estimate_failure(void)
{
    return run.failure;
}

void kernel_estimate_close(void)
{
    struct call_result result;

    if (run.pbo == 0) {
        return;
    }
    if (run.initialized) {
        call(METHOD_KILL, &result); /* whatever it answers, the instance is freed */
    }
    release();
}

void estimator_reset(void)
{
    run.pbo = 0;
    run.instance.area = 0;
    run.inputs = 0;
    run.outputs = 0;
}

void estimator_forget(const struct pbo *pbo)
{
    if (run.pbo == pbo) {
        kernel_estimate_close(); /* its code is about to leave the node */
    }
}
