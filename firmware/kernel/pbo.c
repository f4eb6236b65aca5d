/* pbo.c - one PBO's lifecycle calls and its job (see pbo.h). */
#include "pbo.h"

#include "area.h"
#include "guest_memory.h"
#include "kernel_internal.h"
#include "module_log.h"

uint32_t pbo_stored(const struct pbo *pbo, uint32_t port)
{
    return pbo->store + area_packed(&pbo->module, port, STORED);
}

/* A binding is one byte, the source's slot and its OUT port: slot x ABI_MAX_PORTS + port. */
_Static_assert(KERNEL_MAX_PBOS * ABI_MAX_PORTS <= UNBOUND, "a binding fits a byte");

struct pbo *pbo_source(const struct pbo *pbo, uint32_t port, uint32_t *out)
{
    const uint8_t source = pbo->sources[port];

    if (source == UNBOUND) {
        return 0;
    }
    *out = source % ABI_MAX_PORTS;
    return kernel_slot(source / ABI_MAX_PORTS);
}

void pbo_bind(struct pbo *pbo, uint32_t port, const struct pbo *source, uint32_t out)
{
    pbo->sources[port] = (uint8_t)(kernel_slot_of(source) * ABI_MAX_PORTS + out);
}

static void call(struct pbo *pbo, enum method method, struct call_result *result)
{
    instance_call(&pbo->executor, &pbo->module, kernel_slot_of(pbo), &pbo->performance, method,
                  result);
}

static bool succeeded(const struct call_result *result)
{
    return !result->faulted && result->status == 0;
}

/* "cycle returned -3" or "cycle faulted: <text>" (pbort.errors.describe_failure). */
static void describe_failure(struct text *text, enum method method,
                             const struct call_result *result)
{
    if (result->faulted) {
        text_format(text, "%s faulted: %s", method_name(method), result->fault);
    } else {
        text_format(text, "%s returned %d", method_name(method), result->status);
    }
}

static void note_failure(struct pbo *pbo, enum method method, const struct call_result *result)
{
    struct text failure;
    pbo->counters.faults++;
    text_start(&failure, pbo->counters.last_failure, sizeof pbo->counters.last_failure);
    describe_failure(&failure, method, result);
}

static void call_error(struct pbo *pbo)
{
    struct call_result result;
    call(pbo, METHOD_ERROR, &result);
    if (!succeeded(&result)) {
        note_failure(pbo, METHOD_ERROR, &result);
    }
}

/* Go to `target`, running the actions of the states left and entered. */
static void move(struct pbo *pbo, enum pbo_state target, enum method method,
                 const struct call_result *result)
{
    const enum pbo_state previous = pbo->state;

    if (!succeeded(result)) {
        note_failure(pbo, method, result);
    }
    pbo->state = target;
    if (previous == STATE_ON && target != STATE_ON) {
        scheduler_stop(&pbo->job);
    }
    if (target == previous) {
        return;
    }
    if (target == STATE_ON) {
        scheduler_start(&pbo->job, kernel_now_us());
    } else if (target == STATE_ERROR) {
        call_error(pbo);
    } else if (target == STATE_KILLED) {
        instance_release(&pbo->executor);
    }
}

/* Appends " / "-joined lines to a MethodFailed text: what the module said during the call. */
struct said {
    struct text *text;
    bool first;
};

static void add_said(const struct log_line *line, void *context)
{
    struct said *said = context;
    text_add(said->text, said->first ? "; it logged: " : " / ");
    text_add_bytes(said->text, line->text, line->length);
    said->first = false;
}

static int32_t method_failed(struct pbo *pbo, enum method method,
                             const struct call_result *result, uint32_t before, struct text *why)
{
    struct said said = {why, true};

    text_format(why, "PBO %q: ", pbo->module.name);
    describe_failure(why, method, result);
    text_format(why, "; now %s", state_name(pbo->state));
    module_log_since(pbo->serial, before, add_said, &said);
    return PBO_METHOD_FAILED;
}

/* Create the executor, hand it the constants, run init (pbort's RegisteredPBO.spawn). */
static int32_t spawn(struct pbo *pbo, const struct transition *row, struct text *why)
{
    const uint32_t before = pbo->logged;
    struct call_result result;

    if (!instance_create(&pbo->executor, &pbo->module, ROLE_EXECUTOR, why)) {
        return -1; /* refused before any call: the PBO stays NOT_CREATED */
    }
    for (uint32_t port = 0; port < pbo->module.port_count; port++) {
        const uint8_t direction = pbo->module.ports[port].direction;
        if (direction == DIRECTION_CONST || direction == DIRECTION_RESOURCE) {
            instance_put(&pbo->executor, &pbo->module, port, pbo_stored(pbo, port));
        }
    }
    call(pbo, METHOD_INIT, &result);
    if (!succeeded(&result)) {
        instance_release(&pbo->executor); /* nothing to make safe yet: no error call */
    }
    move(pbo, succeeded(&result) ? row->success : row->failure, METHOD_INIT, &result);
    return succeeded(&result) ? 0 : method_failed(pbo, METHOD_INIT, &result, before, why);
}

int32_t pbo_control(struct pbo *pbo, enum method method, struct text *why)
{
    const struct transition *row =
        lifecycle_transition(pbo->module.name, pbo->state, method, why);
    const uint32_t before = pbo->logged;
    struct call_result result;
    bool entering_error;

    if (row == 0) {
        return -1;
    }
    if (method == METHOD_INIT) {
        return spawn(pbo, row, why);
    }
    call(pbo, method, &result);
    entering_error = !succeeded(&result) && row->failure == STATE_ERROR &&
                     pbo->state != STATE_ERROR;
    move(pbo, succeeded(&result) ? row->success : row->failure, method, &result);
    if (entering_error) {
        pbo_complete(pbo); /* the error method's safe outputs reach the table */
    }
    return succeeded(&result) ? 0 : method_failed(pbo, method, &result, before, why);
}

static void put_inputs(struct pbo *pbo)
{
    for (uint32_t port = 0; port < pbo->module.port_count; port++) {
        uint32_t out;
        const struct pbo *source;
        if (pbo->module.ports[port].direction != DIRECTION_IN) {
            continue;
        }
        source = pbo_source(pbo, port, &out);
        if (source == 0) {
            instance_zero(&pbo->executor, &pbo->module, port);
        } else {
            instance_put(&pbo->executor, &pbo->module, port, pbo_stored(source, out));
        }
    }
}

void pbo_execute(struct pbo *pbo)
{
    struct call_result result;

    put_inputs(pbo);
    call(pbo, METHOD_CYCLE, &result);
    if (!succeeded(&result)) {
        move(pbo, STATE_ERROR, METHOD_CYCLE, &result);
        return;
    }
    call(pbo, METHOD_EVALUATE, &result); /* absent: returns 0 at once */
    if (!succeeded(&result)) {
        move(pbo, STATE_ERROR, METHOD_EVALUATE, &result);
    }
}

void pbo_complete(struct pbo *pbo)
{
    for (uint32_t port = 0; port < pbo->module.port_count; port++) {
        if (pbo->module.ports[port].direction == DIRECTION_OUT) {
            instance_get(&pbo->executor, &pbo->module, port, pbo_stored(pbo, port));
        }
    }
}
