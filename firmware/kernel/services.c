/* services.c - the ecall services and the checks on their arguments (see services.h). */
#include "services.h"

#include <stdarg.h>

#include "area.h"
#include "guest_memory.h"
#include "kernel.h"
#include "kernel_internal.h"
#include "registrar.h"
#include "text.h"

static struct {
    struct call_scope scope;
    bool active;
    bool faulted;
    char fault[SERVICE_FAULT_TEXT];
} current;

void services_enter(const struct call_scope *scope)
{
    current.scope = *scope;
    current.active = true;
    current.faulted = false;
    current.fault[0] = '\0';
}

void services_leave(void)
{
    current.active = false;
}

const char *services_fault(void)
{
    return current.fault[0] != '\0' ? current.fault : "stopped by the board";
}

bool services_faulted(void)
{
    return current.faulted;
}

static int32_t fault(const char *format, ...)
{
    if (current.faulted) {
        return 0; /* the first cause wins, as in services_record_fault */
    }
    struct text why; /* written where it is kept: no second buffer on a module's deepest path */
    va_list arguments;
    text_start(&why, current.fault, sizeof current.fault);
    va_start(arguments, format);
    text_vformat(&why, format, arguments);
    va_end(arguments);
    current.faulted = true;
    return 0;
}

void services_record_fault(const char *text)
{
    if (!current.faulted) { /* the first cause wins: the board may add its own afterwards */
        text_copy(current.fault, text, sizeof current.fault);
        current.faulted = true;
    }
}

/* Record a fault text built from `format` (text_format's conversions). */
static int32_t fault(const char *format, ...);

static int32_t not_available(const char *service)
{
    return fault("%s: not available to %s", service,
                 current.scope.module != 0 ? current.scope.label : "an init subroutine");
}

/* Only the running instance's own context is valid: no other is in the window. */
static bool check_context(uint32_t context, const char *service)
{
    if (context == current.scope.window) {
        return true;
    }
    fault("%s: expected the context %a of %s, got %a", service, current.scope.window,
          current.scope.label, context);
    return false;
}

static bool check_port(uint32_t context, uint32_t port, const char *service)
{
    if (!check_context(context, service)) {
        return false;
    }
    if (port < current.scope.module->port_count) {
        return true;
    }
    fault("%s: expected a port index below %u, got %u", service,
          (uint32_t)current.scope.module->port_count, port);
    return false;
}

/* "PORT_READ of port 0 ('x') into its destination: expected 4 bytes at 0x20000010 inside the
 * task window or the stack, got a buffer in SRAM" */
static void refuse_buffer(const char *service, uint32_t port, const char *end, uint32_t address,
                          uint32_t length, const char *expected)
{
    const char *first = guest_describe(address);
    const char *last = guest_describe(address + length - 1u);

    fault(first == last ? "%s of port %u (%q)%s: expected %u bytes at %a %s, got a buffer in %s"
                        : "%s of port %u (%q)%s: expected %u bytes at %a %s, got a buffer from %s "
                          "into %s",
          service, port, current.scope.module->ports[port].name, end, length, address, expected,
          first, last);
}

static uint32_t window_port(uint32_t port)
{
    return current.scope.window + area_port(current.scope.module, port);
}

static uint32_t buffer_size(uint32_t port)
{
    return port_size(&current.scope.module->ports[port]);
}

static int32_t port_read(uint32_t context, uint32_t port, uint32_t destination, uint32_t length)
{
    uint32_t count;

    if (!check_port(context, port, "PORT_READ")) {
        return 0;
    }
    count = length < buffer_size(port) ? length : buffer_size(port);
    /* the kernel's copy is not bound by the guest's permissions: it must not write where the
     * module itself could not (flash, another module's SRAM) */
    if (count != 0 && !guest_writable(destination, count)) {
        refuse_buffer("PORT_READ", port, " into its destination", destination, count,
                      "inside the task window or the stack");
        return 0;
    }
    guest_copy(destination, window_port(port), count);
    return (int32_t)count;
}

static int32_t port_write(uint32_t context, uint32_t port, uint32_t source, uint32_t length)
{
    uint8_t direction;
    uint32_t count;

    if (!check_port(context, port, "PORT_WRITE")) {
        return 0;
    }
    direction = current.scope.module->ports[port].direction;
    if (direction != DIRECTION_OUT && direction != DIRECTION_RESOURCE) {
        return fault("PORT_WRITE: expected an OUT or RESOURCE port, got port %u (%q) of "
                     "direction %s",
                     port, current.scope.module->ports[port].name,
                     direction == DIRECTION_IN ? "IN" : "CONST");
    }
    count = length < buffer_size(port) ? length : buffer_size(port);
    if (count != 0 && !guest_readable(source, count)) {
        refuse_buffer("PORT_WRITE", port, " from its source", source, count,
                      "inside guest-readable memory");
        return 0;
    }
    guest_copy(window_port(port), source, count);
    return (int32_t)count;
}

static int32_t perf_report(uint32_t context, uint32_t kind, uint32_t index, uint32_t value)
{
    if (!check_context(context, "PERF_REPORT")) {
        return 0;
    }
    if (kind != PERFORMANCE_FUNCTIONAL && kind != PERFORMANCE_NON_FUNCTIONAL) {
        return fault("PERF_REPORT: expected kind 0 (functional) or 1 (non-functional), got %u",
                     kind);
    }
    performance_file(current.scope.performance, (uint8_t)kind, index, (int32_t)value);
    return 0;
}

static int32_t log_text(uint32_t address, uint32_t length)
{
    const char *first;
    const char *last;

    if (length > ABI_LOG_LIMIT) {
        return fault("LOG: expected at most 256 bytes of text, got %u", length);
    }
    if (length != 0 && !guest_readable(address, length)) {
        first = guest_describe(address);
        last = guest_describe(address + length - 1u);
        return fault(first == last ? "LOG text: expected %u bytes at %a inside guest-readable "
                                     "memory, got a buffer in %s"
                                   : "LOG text: expected %u bytes at %a inside guest-readable "
                                     "memory, got a buffer from %s into %s",
                     length, address, first, last);
    }
    kernel_log_line(current.scope.module != 0 ? current.scope.owner : NO_OWNER,
                    length != 0 ? (const char *)guest_bytes(address, length) : "", length);
    return 0;
}

/* The services of a method call; REGISTER and the method-only ones refuse elsewhere. */
static int32_t method_service(uint32_t number, uint32_t a0, uint32_t a1, uint32_t a2, uint32_t a3)
{
    if (number == SERVICE_PORT_READ) {
        return port_read(a0, a1, a2, a3);
    }
    if (number == SERVICE_PORT_WRITE) {
        return port_write(a0, a1, a2, a3);
    }
    if (number == SERVICE_PERF_REPORT) {
        return perf_report(a0, a1, a2, a3);
    }
    return not_available("REGISTER");
}

int32_t services_dispatch(uint32_t number, uint32_t a0, uint32_t a1, uint32_t a2, uint32_t a3)
{
    static const char *const names[] = {"", "REGISTER", "PORT_READ", "PORT_WRITE", "TIME_US",
                                        "LOG", "PERF_REPORT"};

    if (!current.active || number < SERVICE_REGISTER || number > SERVICE_PERF_REPORT) {
        return fault("unknown service %u in a7: expected 1..6", number);
    }
    if (number == SERVICE_TIME_US) {
        return (int32_t)(uint32_t)kernel_now_us(); /* the low 32 bits: wraps every 71 min */
    }
    if (number == SERVICE_LOG) {
        return log_text(a0, a1);
    }
    if (current.scope.module == 0) {
        return number == SERVICE_REGISTER ? registrar_register(a0) : not_available(names[number]);
    }
    return method_service(number, a0, a1, a2, a3);
}

/* --- kernel.h's entry points for the board's trap handler ----------------------------------- */

int32_t kernel_service(uint32_t number, uint32_t a0, uint32_t a1, uint32_t a2, uint32_t a3)
{
    return services_dispatch(number, a0, a1, a2, a3);
}

bool kernel_service_faulted(void)
{
    return services_faulted();
}

void kernel_fault(const char *text)
{
    services_record_fault(text);
}
