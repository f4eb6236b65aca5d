/* svt.c - wiring between PBOs (see svt.h). */
#include "svt.h"

#include "kernel_internal.h"

void svt_add_port(struct text *text, const struct pbo *pbo, uint32_t port)
{
    text_format(text, "%s.%s", pbo->module.name, pbo->module.ports[port].name);
}

/* "<i4 scalar", "<i2 vector of 6", "|u1 frame 2x3 (6 elements)": numpy's names, as the Python
 * kernel describes a port. */
static void add_type(struct text *text, const struct port_spec *spec)
{
    const char *type = spec->element_size == 1 ? "|u1" : spec->element_size == 2 ? "<i2" : "<i4";
    const uint32_t rows = spec->rows;
    const uint32_t columns = spec->columns;

    if (spec->kind == KIND_SCALAR) {
        text_format(text, "%s scalar", type);
    } else if (spec->kind == KIND_VECTOR) {
        text_format(text, "%s vector of %u", type, columns);
    } else {
        text_format(text, "%s frame %ux%u (%u elements)", type, rows, columns, rows * columns);
    }
}

static uint32_t elements(const struct port_spec *spec)
{
    return (uint32_t)spec->rows * spec->columns;
}

static void add_ports(struct text *why, const char *format, const struct pbo *a, uint32_t port_a,
                      const struct pbo *b, uint32_t port_b)
{
    text_format(why, format, a->module.name, a->module.ports[port_a].name, b->module.name,
                b->module.ports[port_b].name);
}

int32_t svt_connect(struct pbo *source, uint32_t source_port, struct pbo *sink,
                    uint32_t sink_port, struct text *why)
{
    const struct port_spec *out = &source->module.ports[source_port];
    const struct port_spec *into = &sink->module.ports[sink_port];
    uint32_t bound;
    const struct pbo *connected = pbo_source(sink, sink_port, &bound);

    if (connected != 0) {
        add_ports(why, "input '%s.%s' is already connected to '%s.%s'; disconnect it first", sink,
                  sink_port, connected, bound);
        return -1;
    }
    if (out->element_size != into->element_size || elements(out) != elements(into)) {
        text_format(why, "cannot connect '%s.%s' (", source->module.name, out->name);
        add_type(why, out);
        text_format(why, ") to '%s.%s' (", sink->module.name, into->name);
        add_type(why, into);
        text_add(why, "): expected the same element type and element count");
        return -1;
    }
    pbo_bind(sink, sink_port, source, source_port);
    kernel_reorder();
    return 0;
}

int32_t svt_disconnect(struct pbo *sink, uint32_t sink_port, struct text *why)
{
    if (sink->sources[sink_port] == UNBOUND) {
        text_format(why, "input '%s.%s' is not connected", sink->module.name,
                    sink->module.ports[sink_port].name);
        return -1;
    }
    sink->sources[sink_port] = UNBOUND;
    kernel_reorder();
    return 0;
}

void svt_forget(const struct pbo *source)
{
    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        struct pbo *pbo = kernel_slot(i);
        for (uint32_t port = 0; pbo->used && port < ABI_MAX_PORTS; port++) {
            uint32_t out;
            if (pbo_source(pbo, port, &out) == source) {
                pbo->sources[port] = UNBOUND;
            }
        }
    }
}

uint32_t svt_value(const struct pbo *pbo, uint32_t port)
{
    uint32_t out;
    const struct pbo *source;

    if (pbo->module.ports[port].direction != DIRECTION_IN) {
        return pbo_stored(pbo, port);
    }
    source = pbo_source(pbo, port, &out);
    return source != 0 ? pbo_stored(source, out) : 0;
}
