/* kernel_control.c - the control requests (kernel.h, "Control requests"), as
 * firmware_sim/serving/kernel_control.py does them on the Python node's kernel. */
#include "kernel.h"

#include "kernel_internal.h"
#include "port_values.h"
#include "svt.h"

static int control(const char *name, enum method method)
{
    struct pbo *pbo = kernel_find(name);
    struct text why;

    if (pbo == 0) {
        return KERNEL_ERR_UNKNOWN; /* kernel_find said so */
    }
    why = kernel_message_text();
    return kernel_result_of(pbo_control(pbo, method, &why));
}

int kernel_spawn(const char *name)
{
    return control(name, METHOD_INIT);
}

int kernel_on(const char *name)
{
    return control(name, METHOD_ON);
}

int kernel_off(const char *name)
{
    return control(name, METHOD_OFF);
}

int kernel_kill(const char *name)
{
    return control(name, METHOD_KILL);
}

int kernel_clear(const char *name)
{
    return control(name, METHOD_CLEAR);
}

int kernel_stop(const char *name)
{
    return control(name, METHOD_OFF);
}

int kernel_start(const char *name)
{
    const struct pbo *pbo = kernel_find(name);
    int result;

    if (pbo == 0) {
        return KERNEL_ERR_UNKNOWN;
    }
    if (pbo->state == STATE_NOT_CREATED) {
        result = kernel_spawn(name);
        if (result != KERNEL_OK) {
            return result;
        }
    }
    return kernel_on(name);
}

static const char *const direction_names[DIRECTION_COUNT] = {"in", "out", "const", "resource"};
static const char *const direction_kinds[DIRECTION_COUNT] = {"an input", "an output", "a constant",
                                                             "a resource"};

int kernel_set_constant(const char *port_name, int64_t value)
{
    uint32_t port;
    struct pbo *pbo = kernel_find_port(port_name, &port);
    const struct port_spec *spec;
    char action_buffer[32];
    struct text action;
    struct text why;

    if (pbo == 0) {
        return KERNEL_ERR_UNKNOWN;
    }
    spec = &pbo->module.ports[port];
    if (spec->direction != DIRECTION_CONST) {
        return kernel_refuse(KERNEL_ERR_REFUSED, "%s is an %s port, not a constant", port_name,
                             direction_names[spec->direction]);
    }
    why = kernel_message_text();
    if (!port_value_exact(port_name, spec, value, &why)) {
        return KERNEL_ERR_REFUSED;
    }
    text_start(&action, action_buffer, sizeof action_buffer);
    text_format(&action, "configure %q", spec->name);
    why = kernel_message_text();
    if (!lifecycle_require(pbo->module.name, pbo->state, action_buffer, CONFIGURABLE, &why)) {
        return KERNEL_ERR_REFUSED;
    }
    port_value_store(pbo_stored(pbo, port), spec->element_size, value);
    if (pbo->executor.area != 0) {
        instance_put(&pbo->executor, &pbo->module, port, pbo_stored(pbo, port));
    }
    return KERNEL_OK;
}

int kernel_set_rate(const char *name, uint32_t millihertz)
{
    struct pbo *pbo;
    struct text why;

    if (!kernel_valid_rate(name, millihertz)) {
        return KERNEL_ERR_REFUSED;
    }
    pbo = kernel_find(name);
    if (pbo == 0) {
        return KERNEL_ERR_UNKNOWN;
    }
    why = kernel_message_text();
    if (!lifecycle_require(name, pbo->state, "change the rate", CONFIGURABLE, &why)) {
        return KERNEL_ERR_REFUSED;
    }
    pbo->job.millihertz = millihertz;
    return KERNEL_OK;
}

/* The port `name` when it has `direction`; else NULL and the Python kernel's refusal. */
static struct pbo *find_wired(const char *name, uint8_t direction, uint32_t *port)
{
    struct pbo *pbo = kernel_find_port(name, port);
    uint8_t found;

    if (pbo == 0) {
        return 0;
    }
    found = pbo->module.ports[*port].direction;
    if (found == direction) {
        return pbo;
    }
    kernel_refuse(0, "port %q is %s port; expected %s", name, direction_kinds[found],
                  direction_kinds[direction]);
    return 0;
}

int kernel_connect(const char *source, const char *sink)
{
    uint32_t out;
    uint32_t in;
    struct pbo *from;
    struct pbo *to;
    struct text why;

    /* both ends must exist before either's direction is judged, as in the Python kernel */
    if (kernel_find_port(source, &out) == 0 || kernel_find_port(sink, &in) == 0) {
        return KERNEL_ERR_UNKNOWN;
    }
    from = find_wired(source, DIRECTION_OUT, &out);
    to = from != 0 ? find_wired(sink, DIRECTION_IN, &in) : 0;
    if (to == 0) {
        return KERNEL_ERR_REFUSED;
    }
    why = kernel_message_text();
    return svt_connect(from, out, to, in, &why) == 0 ? KERNEL_OK : KERNEL_ERR_REFUSED;
}

int kernel_disconnect(const char *source, const char *sink)
{
    uint32_t out;
    uint32_t in;
    struct pbo *from = kernel_find_port(source, &out);
    struct pbo *to = from != 0 ? kernel_find_port(sink, &in) : 0;
    struct text why = kernel_message_text();
    uint32_t bound;

    if (to != 0 && to->module.ports[in].direction == DIRECTION_IN &&
        pbo_source(to, in, &bound) == from && bound == out) {
        return svt_disconnect(to, in, &why) == 0 ? KERNEL_OK : KERNEL_ERR_REFUSED;
    }
    return kernel_refuse(KERNEL_ERR_REFUSED, "input %q is not connected to %q", sink, source);
}

int kernel_read(const char *port_name, int32_t *value)
{
    uint32_t port;
    const struct pbo *pbo = kernel_find_port(port_name, &port);
    const struct port_spec *spec;

    if (pbo == 0) {
        return KERNEL_ERR_UNKNOWN;
    }
    spec = &pbo->module.ports[port];
    if (spec->kind != KIND_SCALAR) {
        return kernel_refuse(KERNEL_ERR_REFUSED, "%s is a %s; only scalar ports are read",
                             port_name, spec->kind == KIND_VECTOR ? "vector" : "frame");
    }
    *value = port_value_read(svt_value(pbo, port), spec->element_size);
    return KERNEL_OK;
}

void kernel_reset(uint32_t *switched_off, uint32_t *wires)
{
    *switched_off = 0;
    *wires = 0;
    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        struct pbo *pbo = &kernel.pbos[i];
        struct text ignored = kernel_message_text();
        if (kernel_admitted(pbo) && pbo->state == STATE_ON) {
            (void)pbo_control(pbo, METHOD_OFF, &ignored);
            (*switched_off)++;
        }
        for (uint32_t port = 0; kernel_admitted(pbo) && port < ABI_MAX_PORTS; port++) {
            *wires += pbo->sources[port] != UNBOUND ? 1u : 0u;
            pbo->sources[port] = UNBOUND;
        }
    }
    kernel_reorder();
    kernel_account_power(); /* what was drawn until now stays drawn */
    kernel.epoch_us = kernel.config.now_us();
    power_restart(&kernel.power);
    timekeeping_restart(&kernel.keeping);
}
