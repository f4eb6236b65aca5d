/*
 * host_driver.c - the kernel on the host, behind a fake board: guest memory in arrays, a
 * virtual clock, modules as C functions (module_call.h's fakes) whose descriptors are bytes in
 * the fake flash. tests/firmware/test_kernel_host.py compiles it with the kernel and runs one
 * scenario per test: `host_driver SCENARIO` prints `key=value` lines for the test to check.
 * `host_driver fuzz` reads descriptors as hex lines on stdin and prints REGISTER's status for
 * each (the hypothesis test).
 */
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../../loader/modules.h"
#include "../abi.h"
#include "../guest_memory.h"
#include "../kernel.h"
#include "../module_call.h"
#include "fake_module.h"

#define FLASH 0x08000000u
#define SRAM 0x20000000u
#define WINDOW 0x30000000u
#define STACK 0x38000000u

/* The Python node's default sizes (docs/memory-map.md), flash aside: the Dehazer's area needs
 * some 40 KiB of SRAM and of task window. */
static uint8_t flash[64 * 1024];
static uint8_t sram[128 * 1024];
static uint8_t window[64 * 1024];
static uint8_t stack[8 * 1024];
static uint64_t now;

static uint64_t clock_now(void) { return now; }
static void clock_wait(uint64_t when) { now = when > now ? when : now; }
static void note(const char *text, uint32_t length) { printf("note=%.*s\n", (int)length, text); }

/* The board's trap handler for an ecall: a refused service ends the call. */
static uint32_t ecall(uint32_t number, uint32_t a0, uint32_t a1, uint32_t a2, uint32_t a3)
{
    const int32_t result = kernel_service(number, a0, a1, a2, a3);
    if (kernel_service_faulted()) {
        module_call_abort();
    }
    return (uint32_t)result;
}

static void boot(void)
{
    const struct kernel_config config = {clock_now, clock_wait, note, 3600000u, 50000u};
    memset(flash, 0, sizeof flash);
    guest_memory_map(REGION_FLASH, FLASH, sizeof flash, flash);
    guest_memory_map(REGION_SRAM, SRAM, sizeof sram, sram);
    guest_memory_map(REGION_WINDOW, WINDOW, sizeof window, window);
    guest_memory_map(REGION_STACK, STACK, sizeof stack, stack);
    module_call_forget_fakes();
    now = 1000;
    kernel_init(&config);
}

/* --- A descriptor in the fake flash ------------------------------------------------------ */

/* An image at FLASH + offset: its descriptor at +0x100, its methods at +4*i (fake code). */
static uint32_t descriptor_at(uint32_t offset, const char *name, uint32_t state_size,
                              const struct fake_port *ports, uint32_t count, uint32_t methods)
{
    fake_module_image(&flash[offset], FLASH + offset, name, state_size, ports, count, methods);
    return FLASH + offset + FAKE_DESCRIPTOR;
}

static uint32_t registering; /* the descriptor the fake init subroutine registers */
static int32_t fake_init(uint32_t argument)
{
    (void)argument;
    (void)ecall(SERVICE_REGISTER, registering, 0, 0, 0);
    return 0;
}

static bool replacing = true; /* false: as at boot, every registered name is taken */

static int32_t install(uint32_t offset, uint32_t descriptor, uint32_t hertz, uint32_t *slot)
{
    int32_t status;
    registering = descriptor;
    module_call_fake(FLASH + offset, fake_init);
    status = kernel_register_module(FLASH + offset, 0x200, FLASH + offset, replacing, slot);
    if (status == 0 && kernel_admit(*slot, hertz * 1000u) != 0) {
        return -100;
    }
    return status;
}

/* --- A gain-like module: y = k * x (plain integers), with an evaluator ---------------------- */

enum { X, Y, K };
static const struct fake_port gain_ports[] = {
    {"x", DIRECTION_IN, KIND_SCALAR, 4, 1, 1},
    {"y", DIRECTION_OUT, KIND_SCALAR, 4, 1, 1},
    {"k", DIRECTION_CONST, KIND_SCALAR, 4, 1, 1},
};
static uint32_t ctx_port(uint32_t ctx, uint32_t port) { return guest_read32(ctx + 4 + 4 * port); }
static int32_t value(uint32_t address) { return (int32_t)guest_read32(address); }

static int32_t gain_on(uint32_t ctx)
{
    static const char said[] = "gain: k is not configured";
    if (value(ctx_port(ctx, K)) == 0) {
        memcpy(&flash[0xF000], said, sizeof said);
        (void)ecall(SERVICE_LOG, FLASH + 0xF000, sizeof said - 1, 0, 0);
        return STATUS_ERR_INVALID;
    }
    return 0;
}

static int32_t gain_cycle(uint32_t ctx)
{
    const uint32_t y = (uint32_t)(value(ctx_port(ctx, K)) * value(ctx_port(ctx, X)));
    guest_write32(STACK + 64, y); /* through the checked service, from the module's stack */
    (void)ecall(SERVICE_PORT_WRITE, ctx, Y, STACK + 64, 4);
    now += 40; /* the cycle takes 40 µs */
    return 0;
}

static int32_t gain_error(uint32_t ctx)
{
    guest_write32(ctx_port(ctx, Y), 0); /* safe output */
    return 0;
}

/* Power: 0.5 mW + 1 mW per 1000 cycles seen, in µW, like the docs' example evaluator. */
static int32_t gain_evaluate(uint32_t ctx)
{
    const uint32_t state = guest_read32(ctx);
    const uint32_t cycles = guest_read32(state) + 1;
    guest_write32(state, cycles);
    (void)ecall(SERVICE_PERF_REPORT, ctx, PERFORMANCE_NON_FUNCTIONAL, 0, 500 + cycles);
    (void)ecall(SERVICE_PERF_REPORT, ctx, PERFORMANCE_FUNCTIONAL, 0, value(ctx_port(ctx, Y)));
    now += 10;
    return 0;
}

/* The estimator: the same function on its own ports; fails when x is 13. */
static int32_t gain_estimate(uint32_t ctx)
{
    const int32_t x = value(ctx_port(ctx, X));
    if (x == 13) {
        return STATUS_ERR_INVALID;
    }
    guest_write32(ctx_port(ctx, Y), (uint32_t)(value(ctx_port(ctx, K)) * x));
    (void)ecall(SERVICE_PERF_REPORT, ctx, PERFORMANCE_FUNCTIONAL, 0, value(ctx_port(ctx, Y)));
    return 0;
}

/* A source: y = its cycle count. */
static int32_t ramp_cycle(uint32_t ctx)
{
    const uint32_t state = guest_read32(ctx);
    guest_write32(state, guest_read32(state) + 1);
    guest_write32(ctx_port(ctx, 0), guest_read32(state));
    return 0;
}

#define BIT(m) (1u << (m))

static void install_gain(uint32_t offset, const char *name, uint32_t hertz)
{
    uint32_t slot;
    const uint32_t entry = FLASH + offset;
    const uint32_t d = descriptor_at(offset, name, 8, gain_ports, 3,
                                     BIT(METHOD_ON) | BIT(METHOD_CYCLE) | BIT(METHOD_ERROR) |
                                         BIT(METHOD_EVALUATE) | BIT(METHOD_ESTIMATE));
    module_call_fake(entry + 4 * (METHOD_ON + 1), gain_on);
    module_call_fake(entry + 4 * (METHOD_CYCLE + 1), gain_cycle);
    module_call_fake(entry + 4 * (METHOD_ERROR + 1), gain_error);
    module_call_fake(entry + 4 * (METHOD_EVALUATE + 1), gain_evaluate);
    module_call_fake(entry + 4 * (METHOD_ESTIMATE + 1), gain_estimate);
    printf("install.%s=%d\n", name, install(offset, d, hertz, &slot));
}

static void install_ramp(uint32_t offset, uint32_t hertz)
{
    static const struct fake_port ports[] = {{"y", DIRECTION_OUT, KIND_SCALAR, 4, 1, 1}};
    uint32_t slot;
    const uint32_t d = descriptor_at(offset, "ramp", 4, ports, 1, BIT(METHOD_CYCLE));
    module_call_fake(FLASH + offset + 4 * (METHOD_CYCLE + 1), ramp_cycle);
    printf("install.ramp=%d\n", install(offset, d, hertz, &slot));
}

static void said(const char *what, int result)
{
    printf("%s=%d %s\n", what, result, result != 0 ? kernel_message() : "");
}

static void show(const char *port)
{
    int32_t v = 0;
    const int result = kernel_read(port, &v);
    if (result == 0) {
        printf("read.%s=%d\n", port, v);
    } else {
        said(port, result);
    }
}

static void show_state(const char *name)
{
    struct kernel_pbo row;
    for (uint32_t i = 0; kernel_pbo_at(i, &row); i++) {
        if (strcmp(row.name, name) == 0) {
            printf("state.%s=%s\n", name, row.state);
        }
    }
}

static void show_stats(const char *name)
{
    struct kernel_stats stats;
    if (kernel_stats(name, &stats) == 0) {
        printf("stats.%s=cycles:%u missed:%u overruns:%u long:%u faults:%u busy:%llu\n", name,
               stats.cycles, stats.missed_deadlines, stats.overruns, stats.long_jobs,
               stats.faults, (unsigned long long)stats.busy_time_us);
        printf("failure.%s=%s\n", name, stats.last_failure);
    }
}

/* --- Scenarios ------------------------------------------------------------------------------ */

static void scenario_lifecycle(void)
{
    install_gain(0x0000, "gain", 100);
    show_state("gain");
    said("on_before_init", kernel_on("gain"));
    said("clear_not_error", kernel_clear("gain"));
    said("start_unconfigured", kernel_start("gain"));
    show_state("gain");
    said("on_in_error", kernel_on("gain"));
    said("set_in_error", kernel_set_constant("gain.k", 3));
    said("clear", kernel_clear("gain"));
    show_state("gain");
    said("set_k", kernel_set_constant("gain.k", 3));
    said("set_range", kernel_set_constant("gain.k", 5000000000LL));
    said("set_input", kernel_set_constant("gain.x", 1));
    said("start", kernel_start("gain"));
    show_state("gain");
    said("set_while_on", kernel_set_constant("gain.k", 4));
    said("rate_while_on", kernel_set_rate("gain", 5000));
    said("kill_while_on", kernel_kill("gain"));
    said("stop", kernel_stop("gain"));
    said("kill", kernel_kill("gain"));
    show_state("gain");
    said("unknown", kernel_start("nope"));
    said("stop_unknown", kernel_stop("nope"));
    show_stats("gain");
}

static void scenario_wiring(void)
{
    install_ramp(0x0000, 100);
    install_gain(0x1000, "gain", 100);
    said("connect_wrong_way", kernel_connect("gain.x", "ramp.y"));
    said("connect_to_nothing", kernel_connect("gain.x", "ramp.z"));
    said("connect_const", kernel_connect("ramp.y", "gain.k"));
    said("connect", kernel_connect("ramp.y", "gain.x"));
    said("connect_again", kernel_connect("ramp.y", "gain.x"));
    said("set_k", kernel_set_constant("gain.k", 3));
    said("start_ramp", kernel_start("ramp"));
    said("start_gain", kernel_start("gain"));
    printf("ran=%u\n", kernel_run(1000000, UINT32_MAX)); /* one second of kernel time */
    show("ramp.y");
    show("gain.x");
    show("gain.y");
    show("gain.k");
    show_stats("gain");
    said("disconnect_wrong", kernel_disconnect("gain.y", "gain.x"));
    said("disconnect", kernel_disconnect("ramp.y", "gain.x"));
    kernel_run(1010000, UINT32_MAX);
    {
        int32_t y = -1;
        kernel_read("gain.y", &y);
        printf("disconnected.gain.y=%d\n", y);
    }
}

static void scenario_rate(void)
{
    install_gain(0x0000, "slow", 10);
    said("set_k", kernel_set_constant("slow.k", 1));
    said("rate_low", kernel_set_rate("slow", 5));
    said("rate", kernel_set_rate("slow", 25000)); /* 25 Hz */
    said("start", kernel_start("slow"));
    printf("ran=%u\n", kernel_run(1000000, UINT32_MAX));
    show_stats("slow");
}

/* A 100 Hz PBO whose cycle takes 12 ms: 50 cycles in a second, all late (docs/pbort.md). */
static int32_t hog_cycle(uint32_t ctx)
{
    (void)ctx;
    now += 12000;
    return 0;
}

static void hog_module(uint32_t offset, const char *name, uint32_t hertz)
{
    static const struct fake_port ports[] = {{"y", DIRECTION_OUT, KIND_SCALAR, 4, 1, 1}};
    uint32_t slot;
    const uint32_t d = descriptor_at(offset, name, 0, ports, 1, BIT(METHOD_CYCLE));
    module_call_fake(FLASH + offset + 4 * (METHOD_CYCLE + 1), hog_cycle);
    printf("install.%s=%d\n", name, install(offset, d, hertz, &slot));
}

static void scenario_overrun(void)
{
    hog_module(0, "hog", 100);
    said("start", kernel_start("hog"));
    printf("ran=%u\n", kernel_run(1000000, UINT32_MAX));
    show_stats("hog");
}

/* A 10 Hz PBO that says when each of its cycles starts. */
static int32_t stamp_cycle(uint32_t ctx)
{
    (void)ctx;
    printf("cycle_at=%llu\n", (unsigned long long)kernel_time_us()); /* from its zero */
    return 0;
}

/* Switched on at 50 ms and at 420 ms: released then, and on the 10 Hz grid from the clock's
 * zero in between (pbort/scheduler.py). */
static void scenario_grid(void)
{
    static const struct fake_port ports[] = {{"y", DIRECTION_OUT, KIND_SCALAR, 4, 1, 1}};
    uint32_t slot;
    const uint32_t d = descriptor_at(0, "stamp", 0, ports, 1, BIT(METHOD_CYCLE));
    module_call_fake(FLASH + 4 * (METHOD_CYCLE + 1), stamp_cycle);
    printf("install.stamp=%d\n", install(0, d, 10, &slot));
    kernel_run(50000, UINT32_MAX);
    said("start", kernel_start("stamp"));
    kernel_run(300000, UINT32_MAX);
    said("stop", kernel_stop("stamp"));
    kernel_run(420000, UINT32_MAX);
    said("start_again", kernel_start("stamp"));
    kernel_run(600000, UINT32_MAX);
}

/* A chain ramp -> first -> second registered against its flow: the ties of a release go by
 * the wiring (flow_order.c), so the ramp's value crosses both in the same period. */
static void scenario_flow(void)
{
    install_gain(0x0000, "second", 100);
    install_gain(0x1000, "first", 100);
    install_ramp(0x2000, 100);
    said("connect_first", kernel_connect("ramp.y", "first.x"));
    said("connect_second", kernel_connect("first.y", "second.x"));
    said("set_first", kernel_set_constant("first.k", 1));
    said("set_second", kernel_set_constant("second.k", 1));
    said("start_second", kernel_start("second"));
    said("start_first", kernel_start("first"));
    said("start_ramp", kernel_start("ramp"));
    kernel_run(1000000, UINT32_MAX);
    show("ramp.y");
    show("second.y");
}

static void scenario_evaluator(void)
{
    struct kernel_status status;
    uint8_t kind;
    uint32_t index;
    int32_t milli;

    install_gain(0x0000, "gain", 100);
    said("set_k", kernel_set_constant("gain.k", 2));
    said("start", kernel_start("gain"));
    kernel_run(1000000, UINT32_MAX);
    for (uint32_t n = 0; kernel_performance_at(0, n, &kind, &index, &milli); n++) {
        printf("perf.%c%u=%d\n", kind == 0 ? 'F' : 'N', index, milli);
    }
    kernel_status(0, &status);
    printf("leftover=%u\n", status.leftover_milli);
    /* an hour at 50 mW base draw plus the module's ~0.6 mW: 180 J of 3600 J, ~5 %% used */
    kernel_run(3600000000ull, UINT32_MAX);
    kernel_status(0, &status);
    printf("leftover_hour=%u\n", status.leftover_milli);
}

/* Bad service arguments fault the module into ERROR (PORT_WRITE to an input). */
static int32_t bad_cycle(uint32_t ctx)
{
    (void)ecall(SERVICE_PORT_WRITE, ctx, X, STACK, 4);
    return 0;
}

static int32_t foreign_context(uint32_t ctx)
{
    (void)ecall(SERVICE_PERF_REPORT, ctx + 8, 0, 0, 1);
    return 0;
}

static int32_t read_into_sram(uint32_t ctx)
{
    (void)ecall(SERVICE_PORT_READ, ctx, X, SRAM, 4);
    return 0;
}

static void fault_case(const char *name, module_fake cycle)
{
    uint32_t slot;
    uint32_t d;
    boot();
    d = descriptor_at(0, name, 0, gain_ports, 3, BIT(METHOD_CYCLE) | BIT(METHOD_ERROR));
    module_call_fake(FLASH + 4 * (METHOD_CYCLE + 1), cycle);
    module_call_fake(FLASH + 4 * (METHOD_ERROR + 1), gain_error);
    printf("install.%s=%d\n", name, install(0, d, 100, &slot));
    said("start", kernel_start(name));
    kernel_run(100000, UINT32_MAX);
    show_state(name);
    show_stats(name);
}

static void scenario_faults(void)
{
    fault_case("writer", bad_cycle);
    fault_case("foreign", foreign_context);
    fault_case("reader", read_into_sram);
}

/* SRAM blocks never overlap: a block freed between two others is reused only by an area that
 * fits it, so a module's area never covers another PBO's output variable. */
static int32_t seventy_seven(uint32_t ctx)
{
    guest_write32(ctx_port(ctx, 0), 77);
    guest_write32(ctx_port(ctx, 1), 77);
    return 0;
}

static void scenario_isolation(void)
{
    static const struct fake_port in[] = {{"x", DIRECTION_IN, KIND_SCALAR, 4, 1, 1}};
    static const struct fake_port out[] = {{"y0", DIRECTION_OUT, KIND_SCALAR, 4, 1, 1},
                                      {"y1", DIRECTION_OUT, KIND_SCALAR, 4, 1, 1}};
    uint32_t slot;

    /* a's area (64 bytes) first, then c's two output variables (16 bytes) right after it */
    printf("install.a=%d\n", install(0x0000, descriptor_at(0x0000, "a", 16, in, 1, 0), 100, &slot));
    said("spawn_a", kernel_spawn("a"));
    module_call_fake(FLASH + 0x1000 + 4 * (METHOD_CYCLE + 1), seventy_seven);
    printf("install.c=%d\n",
           install(0x1000, descriptor_at(0x1000, "c", 0, out, 2, BIT(METHOD_CYCLE)), 100, &slot));
    said("start_c", kernel_start("c"));
    kernel_run(kernel_time_us() + 5000, 1);
    said("stop_c", kernel_stop("c"));
    said("remove_a", kernel_remove("a"));
    /* d's area (72 bytes) does not fit the 64 bytes a left: it goes after c's variables */
    printf("install.d=%d\n", install(0x2000, descriptor_at(0x2000, "d", 24, in, 1, 0), 100, &slot));
    said("spawn_d", kernel_spawn("d"));
    show("c.y0");
}

/* A shadow run beside the running configuration: its own instance, the live input's snapshot,
 * given values first; the live PBOs go on exactly as before. */
static void show_estimate(const char *port)
{
    int32_t v = 0;
    const int result = kernel_estimate_read(port, &v);
    printf("estimate.%s=%d %s\n", port, result == 0 ? v : result, result ? kernel_message() : "");
}

static void scenario_estimator(void)
{
    uint32_t done = 0;
    uint8_t kind;
    uint32_t index;
    int32_t milli;

    install_ramp(0x0000, 100);
    install_gain(0x1000, "gain", 100);
    said("connect", kernel_connect("ramp.y", "gain.x"));
    said("set_k", kernel_set_constant("gain.k", 3));
    said("start_ramp", kernel_start("ramp"));
    said("start_gain", kernel_start("gain"));
    kernel_run(100000, UINT32_MAX); /* 10 cycles: ramp.y is 10 */
    said("open_ramp", kernel_estimate_open("ramp"));
    said("open", kernel_estimate_open("gain"));
    said("open_twice", kernel_estimate_open("gain"));
    said("give_output", kernel_estimate_give("gain.y", 1));
    said("give_k", kernel_estimate_give("gain.k", 5));
    said("run", kernel_estimate_run(2, &done));
    printf("done=%u\n", done);
    show_estimate("gain.x"); /* the snapshot of ramp.y */
    show_estimate("gain.y");
    for (uint32_t n = 0; kernel_estimate_performance_at(n, &kind, &index, &milli); n++) {
        printf("estimate.perf.%c%u=%d\n", kind == 0 ? 'F' : 'N', index, milli);
    }
    said("give_late", kernel_estimate_give("gain.x", 13));
    kernel_estimate_close();
    said("reopen", kernel_estimate_open("gain"));
    said("give_x", kernel_estimate_give("gain.x", 13));
    said("run_failing", kernel_estimate_run(3, &done));
    printf("done_failing=%u\n", done);
    printf("estimate.failure=%s\n", kernel_estimate_failure());
    kernel_estimate_close();
    said("open_live", kernel_estimate_open("gain")); /* the live constant k = 3 comes along */
    said("run_live", kernel_estimate_run(1, &done));
    {
        int32_t y = 0;
        kernel_estimate_read("gain.y", &y);
        printf("estimate.live.y=%d\n", y);
    }
    kernel_estimate_close();
    show("gain.k"); /* the live PBO's constant, untouched */
    kernel_run(200000, UINT32_MAX);
    show("gain.y"); /* the live PBO goes on: 3 x ramp.y = 3 x 20 */
    show_stats("gain");
}

/* Slip: the firmware spent 50 ms elsewhere (a flash erase) while a job was due. */
static void scenario_slip(void)
{
    struct kernel_status status;

    install_gain(0x0000, "gain", 100);
    said("set_k", kernel_set_constant("gain.k", 1));
    said("start", kernel_start("gain"));
    kernel_run(500000, UINT32_MAX);
    now += 50000;
    kernel_run(1000000, UINT32_MAX);
    kernel_status(0, &status);
    printf("slip=%llu missed=%u\n", (unsigned long long)status.slip_us, status.missed);
    kernel_status(600000, &status);
    printf("slip_since_600ms=%llu\n", (unsigned long long)status.slip_us);
    show_stats("gain");
}

/* A PBO whose job holds the CPU past its period: its lateness is modelled, not slip; only the
 * time the firmware was away is. With gain released at the same instants behind it. */
static void hog_module(uint32_t offset, const char *name, uint32_t hertz);

static void scenario_busy(void)
{
    struct kernel_status status;

    hog_module(0x0000, "hog", 10);
    install_gain(0x1000, "gain", 10);
    said("set_k", kernel_set_constant("gain.k", 1));
    said("start_hog", kernel_start("hog"));
    said("start_gain", kernel_start("gain"));
    kernel_run(1000000, UINT32_MAX);
    kernel_status(0, &status);
    printf("slip=%llu missed=%u\n", (unsigned long long)status.slip_us, status.missed);
    kernel_reset(&(uint32_t){0}, &(uint32_t){0}); /* both off, the clock from 0 */
    said("rate_hog", kernel_set_rate("hog", 100000));
    said("restart_hog", kernel_start("hog"));
    kernel_run(500000, UINT32_MAX); /* 12 ms jobs every 20 ms: 500 ms then the job at 500 */
    now += 50000;
    kernel_run(600000, UINT32_MAX);
    kernel_status(0, &status);
    printf("long_slip=%llu missed=%u\n", (unsigned long long)status.slip_us, status.missed);
}

/* A module that logs every cycle: the newest lines are kept, numbered from 1. */
static int32_t chatty_cycle(uint32_t ctx)
{
    const uint32_t state = guest_read32(ctx);
    const uint32_t count = guest_read32(state) + 1;
    char line[32];
    const int length = snprintf(line, sizeof line, "tick %u", count);
    guest_write32(state, count);
    memcpy(&window[0], line, (size_t)length); /* the text, in the module's own window */
    (void)ecall(SERVICE_LOG, WINDOW, (uint32_t)length, 0, 0);
    return 0;
}

static void print_line(const struct log_line *line, void *context)
{
    (void)context;
    printf("line=%u %llu %.*s\n", line->number, (unsigned long long)line->time_us,
           (int)line->length, line->text);
}

static void scenario_log(void)
{
    static const struct fake_port out[] = {{"y", DIRECTION_OUT, KIND_SCALAR, 4, 1, 1}};
    struct kernel_stats stats;
    uint32_t slot;

    module_call_fake(FLASH + 4 * (METHOD_CYCLE + 1), chatty_cycle);
    printf("install=%d\n", install(0, descriptor_at(0, "chatty", 4, out, 1, BIT(METHOD_CYCLE)),
                                    100, &slot));
    said("start", kernel_start("chatty"));
    kernel_run(1000000, UINT32_MAX);
    kernel_stats("chatty", &stats);
    printf("logged=%u\n", stats.logged);
    kernel_log("chatty", 97, print_line, NULL);
    printf("since0\n");
    kernel_log("chatty", 0, print_line, NULL);
}

/* The loader's seam: a module registers under its descriptor's name, or is refused. */
static void scenario_loader(void)
{
    const uint32_t d = descriptor_at(0, "gain", 0, gain_ports, 3, 0);
    const char *refusal;
    struct kernel_pbo row;

    registering = d;
    module_call_fake(FLASH, fake_init);
    refusal = node_module_installed("other", FLASH, 0x200, FLASH);
    printf("installed_misnamed=%s\n", refusal != NULL ? refusal : "");
    printf("pbos_after_refusal=%u\n", kernel_pbo_count());
    refusal = node_module_installed("gain", FLASH, 0x200, FLASH);
    printf("installed=%s\n", refusal != NULL ? refusal : "");
    kernel_pbo_at(0, &row);
    printf("row=%s %s %u\n", row.name, row.state, row.millihertz);
    refusal = node_module_installed("gain", FLASH, 0x200, FLASH); /* a new version of it */
    printf("replaced=%s count=%u\n", refusal != NULL ? refusal : "", kernel_pbo_count());
    node_module_removed("gain");
    printf("pbos_after_removal=%u\n", kernel_pbo_count());
}

/* --- Registration refusals --------------------------------------------------------------- */

static void refusal(const char *what, uint32_t offset, uint32_t descriptor)
{
    uint32_t slot;
    const int32_t status = install(offset, descriptor, 100, &slot);
    printf("register.%s=%d %s\n", what, status, status != 0 ? kernel_message() : "");
}

static void scenario_register(void)
{
    static const struct fake_port dup[] = {
        {"x", DIRECTION_IN, KIND_SCALAR, 4, 1, 1}, {"x", DIRECTION_OUT, KIND_SCALAR, 4, 1, 1}};
    static const struct fake_port shape[] = {{"v", DIRECTION_IN, KIND_VECTOR, 4, 2, 3}};
    static const struct fake_port size3[] = {{"v", DIRECTION_IN, KIND_SCALAR, 3, 1, 1}};
    static const struct fake_port huge[] = {{"f", DIRECTION_IN, KIND_FRAME, 4, 512, 512}};
    uint32_t d;

    replacing = false;
    refusal("ok", 0x0000, descriptor_at(0x0000, "first", 0, gain_ports, 3, BIT(METHOD_CYCLE)));
    refusal("exists", 0x1000, descriptor_at(0x1000, "first", 0, gain_ports, 3, 0));
    d = descriptor_at(0x2000, "magic", 0, gain_ports, 3, 0);
    flash[d - FLASH] ^= 1;
    refusal("magic", 0x2000, d);
    d = descriptor_at(0x3000, "abi", 0, gain_ports, 3, 0);
    fake_put16(&flash[d - FLASH + 4], 2);
    refusal("abi", 0x3000, d);
    refusal("dup", 0x4000, descriptor_at(0x4000, "dup", 0, dup, 2, 0));
    refusal("shape", 0x5000, descriptor_at(0x5000, "shape", 0, shape, 1, 0));
    refusal("size3", 0x6000, descriptor_at(0x6000, "sized", 0, size3, 1, 0));
    refusal("name", 0x7000, descriptor_at(0x7000, "9lives", 0, gain_ports, 3, 0));
    refusal("huge", 0x8000, descriptor_at(0x8000, "huge", 0, huge, 1, 0));
    d = descriptor_at(0x9000, "method", 0, gain_ports, 3, BIT(METHOD_ON));
    fake_put32(&flash[d - FLASH + 192], FLASH + 0x9002); /* not 4-byte aligned */
    refusal("method", 0x9000, d);
    refusal("outside", 0xA000, FLASH + 0xA000 + 0x180); /* 224 bytes past the image's end */
    d = descriptor_at(0xB000, "ports", 0, gain_ports, 3, 0);
    fake_put16(&flash[d - FLASH + 6], 9);
    refusal("ports", 0xB000, d);
}

/* --- A real module's image: the SDK's build, placed at its link base ---------------------- */

#define LINK_BASE 0x00010000u

/* Register the image in file `path` (a module's .bin, linked at LINK_BASE and placed there, so
 * no pointer needs relocating) and list the PBO it becomes, as PS would. */
static void image(const char *path)
{
    FILE *file = fopen(path, "rb");
    const size_t size = file != NULL ? fread(flash, 1, sizeof flash, file) : 0;
    struct kernel_pbo row;
    uint32_t slot;
    int32_t status;

    if (file != NULL) {
        fclose(file);
    }
    guest_memory_map(REGION_FLASH, LINK_BASE, sizeof flash, flash);
    registering = LINK_BASE + (uint32_t)size - ABI_DESCRIPTOR_SIZE; /* the image's last part */
    module_call_fake(LINK_BASE, fake_init);
    status = kernel_register_module(LINK_BASE, (uint32_t)size, LINK_BASE, false, &slot);
    printf("register=%d %s\n", status, status != 0 ? kernel_message() : "");
    if (status != 0 || kernel_admit(slot, 100000) != 0 || !kernel_pbo_at(0, &row)) {
        return;
    }
    printf("pbo=%s %s\n", row.name, row.state);
    for (uint32_t i = 0; i < row.port_count; i++) {
        printf("port=%s %u %u %u\n", row.port_names[i], row.port_directions[i], row.port_kinds[i],
               row.element_sizes[i]);
    }
}

/* --- Fuzz: descriptors from stdin --------------------------------------------------------- */

static int32_t fuzz_cycle(uint32_t ctx) { (void)ctx; return 0; }

static void fuzz(void)
{
    char line[2 * ABI_DESCRIPTOR_SIZE + 8];
    boot();
    while (fgets(line, sizeof line, stdin) != NULL) {
        uint32_t slot;
        int32_t status;
        for (uint32_t i = 0; i < ABI_DESCRIPTOR_SIZE && line[2 * i] && line[2 * i + 1]; i++) {
            unsigned byte;
            sscanf(&line[2 * i], "%2x", &byte);
            flash[0x100 + i] = (uint8_t)byte;
        }
        registering = FLASH + 0x100;
        module_call_fake(FLASH, fake_init);
        for (uint32_t m = 0; m < METHOD_COUNT; m++) {
            module_call_fake(FLASH + 4 * (m + 1), fuzz_cycle);
        }
        status = kernel_register_module(FLASH, 0x200, FLASH, false, &slot);
        printf("%d %s\n", status, status != 0 ? kernel_message() : "");
        if (status == 0) {
            /* run it once through its lifecycle, then make room for the next one */
            kernel_admit(slot, 100000);
            kernel_start(kernel_module_name(slot));
            kernel_run(kernel_time_us() + 20000, 4);
            kernel_remove(kernel_module_name(slot));
        }
        fflush(stdout);
    }
}

int main(int argc, char **argv)
{
    static const struct {
        const char *name;
        void (*run)(void);
    } scenarios[] = {
        {"lifecycle", scenario_lifecycle}, {"wiring", scenario_wiring},
        {"rate", scenario_rate},           {"overrun", scenario_overrun},
        {"evaluator", scenario_evaluator}, {"faults", scenario_faults},
        {"register", scenario_register},   {"isolation", scenario_isolation},
        {"estimator", scenario_estimator}, {"loader", scenario_loader},
        {"slip", scenario_slip},           {"log", scenario_log},
        {"busy", scenario_busy},           {"grid", scenario_grid},
        {"flow", scenario_flow},           {"fuzz", fuzz},
    };
    if (argc == 3 && strcmp(argv[1], "image") == 0) {
        boot();
        image(argv[2]);
        return 0;
    }
    for (size_t i = 0; argc == 2 && i < sizeof scenarios / sizeof scenarios[0]; i++) {
        if (strcmp(argv[1], scenarios[i].name) == 0) {
            boot();
            scenarios[i].run();
            return 0;
        }
    }
    fprintf(stderr, "usage: host_driver SCENARIO | host_driver image MODULE.bin\n");
    return 2;
}
