/* kernel_observe.c - what a host reads of the node (kernel.h, "Observation"): PS rows, counters,
 * wires, log lines, the node's status and each PBO's latest performance values, and the power
 * accounting that the status reports. */
#include "kernel.h"

#include "kernel_internal.h"
#include "power.h"
#include "svt.h"

/* The admitted PBO of rank `index` in registration order. */
struct pbo *kernel_at_rank(uint32_t index)
{
    uint32_t after = 0;
    for (uint32_t rank = 0; rank <= index; rank++) {
        struct pbo *best = 0;
        for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
            struct pbo *pbo = &kernel.pbos[i];
            const bool later = kernel_admitted(pbo) && pbo->serial > after;
            if (later && (best == 0 || pbo->serial < best->serial)) {
                best = pbo;
            }
        }
        if (best == 0) {
            return 0;
        }
        after = best->serial;
        if (rank == index) {
            return best;
        }
    }
    return 0;
}

uint32_t kernel_pbo_count(void)
{
    uint32_t count = 0;
    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        count += kernel_admitted(&kernel.pbos[i]) ? 1u : 0u;
    }
    return count;
}

bool kernel_pbo_at(uint32_t index, struct kernel_pbo *row)
{
    const struct pbo *pbo = kernel_at_rank(index);
    if (pbo == 0) {
        return false;
    }
    row->name = pbo->module.name;
    row->state = state_name(pbo->state);
    row->millihertz = pbo->job.millihertz;
    row->port_count = pbo->module.port_count;
    for (uint32_t port = 0; port < pbo->module.port_count; port++) {
        row->port_names[port] = pbo->module.ports[port].name;
        row->port_directions[port] = pbo->module.ports[port].direction;
        row->port_kinds[port] = pbo->module.ports[port].kind;
        row->element_sizes[port] = pbo->module.ports[port].element_size;
    }
    return true;
}

int kernel_stats(const char *name, struct kernel_stats *stats)
{
    const struct pbo *pbo = kernel_find(name);
    const struct counters *counters;

    if (pbo == 0) {
        return KERNEL_ERR_UNKNOWN;
    }
    counters = &pbo->counters;
    stats->cycles = counters->cycles;
    stats->missed_deadlines = counters->missed_deadlines;
    stats->overruns = counters->overruns;
    stats->long_jobs = counters->long_jobs;
    stats->faults = counters->faults;
    stats->busy_time_us = counters->busy_time_us;
    stats->last_failure = counters->last_failure;
    stats->logged = pbo->logged;
    return KERNEL_OK;
}

static void port_text(char *buffer, const struct pbo *pbo, uint32_t port)
{
    struct text text;
    text_start(&text, buffer, 32);
    svt_add_port(&text, pbo, port);
}

bool kernel_wire_at(const char *name, uint32_t n, char *source, char *sink)
{
    for (uint32_t rank = 0; kernel_at_rank(rank) != 0; rank++) {
        const struct pbo *pbo = kernel_at_rank(rank);
        for (uint32_t port = 0; port < pbo->module.port_count; port++) {
            uint32_t out;
            const struct pbo *from = pbo_source(pbo, port, &out);
            if (from == 0) {
                continue;
            }
            if (name != 0 && !text_equal(name, pbo->module.name) &&
                !text_equal(name, from->module.name)) {
                continue;
            }
            if (n-- == 0) {
                port_text(source, from, out);
                port_text(sink, pbo, port);
                return true;
            }
        }
    }
    return false;
}

int kernel_log(const char *name, uint32_t since, log_visitor visit, void *context)
{
    const struct pbo *pbo = kernel_find(name);
    if (pbo == 0) {
        return KERNEL_ERR_UNKNOWN;
    }
    module_log_since(pbo->serial, since, visit, context);
    return KERNEL_OK;
}

/* Energy drawn since the last accounting at the draws accepted then, then each ON PBO's latest
 * non-functional value 0 as its new draw (firmware_sim's Node._account_power). */
void kernel_account_power(void)
{
    uint64_t draw = kernel.power.base_draw_uw;
    static const char refused[] = "power: a module reported a negative draw; its draw is not "
                                  "counted until it reports one";

    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        draw += kernel.draws_uw[i];
    }
    power_advance(&kernel.power, kernel_now_us(), draw);
    for (uint32_t i = 0; i < KERNEL_MAX_PBOS; i++) {
        const struct pbo *pbo = &kernel.pbos[i];
        const struct performance_value *latest =
            kernel_admitted(pbo) && pbo->state == STATE_ON
                ? performance_latest(&pbo->performance, PERFORMANCE_NON_FUNCTIONAL, 0)
                : 0;
        kernel.draws_uw[i] = latest != 0 && latest->value_milli > 0 ? (uint32_t)latest->value_milli
                                                                     : 0;
        if (latest != 0 && latest->value_milli < 0 && !kernel.draw_refused[i]) {
            kernel_note(refused, sizeof refused - 1u);
        }
        kernel.draw_refused[i] = latest != 0 && latest->value_milli < 0;
    }
}

void kernel_status(uint64_t since_us, struct kernel_status *status)
{
    kernel_account_power();
    status->leftover_milli = power_leftover_milli(&kernel.power);
    status->slip_us = timekeeping_worst_since(&kernel.keeping, since_us);
    status->missed = kernel.keeping.missed;
}

bool kernel_performance_at(uint32_t index, uint32_t n, uint8_t *kind, uint32_t *value_index,
                           int32_t *value_milli)
{
    const struct pbo *pbo = kernel_at_rank(index);

    return pbo != 0 && pbo->state == STATE_ON &&
           performance_ranked(&pbo->performance, n, kind, value_index, value_milli);
}
