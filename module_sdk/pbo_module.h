/*
 * pbo_module.h - the ABI between a migrating module (guest code) and the PBO/RT kernel.
 *
 * A module is C compiled for RV32IM with -mcmodel=medany and no libc, linked at the link base
 * by module.ld. The node loads it anywhere in flash, fixes the descriptor's method pointers
 * (the only absolute words in the image) and calls module_init, which hands the descriptor to
 * the kernel. From then on the kernel calls the methods, each with a context it built in SRAM.
 *
 * This header mirrors docs/module-abi.md; change both together and bump PBO_ABI_VERSION when
 * a layout or a service changes.
 *
 * Freestanding C99 (plus _Static_assert and GNU inline asm): only <stdint.h> and <stddef.h>.
 */
#ifndef PBO_MODULE_H
#define PBO_MODULE_H

#include <stddef.h>
#include <stdint.h>

#define PBO_ABI_VERSION 1
#define PBO_MAGIC 0x314F4250u /* "PBO1" as a little-endian word */
#define PBO_NAME_LEN 16       /* module name, NUL-terminated: at most 15 characters */
#define PBO_PORT_NAME_LEN 12  /* port name, NUL-terminated: at most 11 characters */
#define PBO_MAX_PORTS 8

/* Port direction, after Stewart's port-based objects. */
enum pbo_port_direction {
    PBO_PORT_IN = 0,       /* variable input: filled from the state-variable table before cycle */
    PBO_PORT_OUT = 1,      /* variable output: copied to the state-variable table after cycle */
    PBO_PORT_CONST = 2,    /* configuration constant: set by whoever configures the module */
    PBO_PORT_RESOURCE = 3, /* resource: a sensor or actuator behind a peripheral driver */
};

/*
 * What a port carries; rows x columns elements of element_size bytes give its shape and its
 * buffer size, element_size * rows * columns bytes.
 */
enum pbo_port_type {
    PBO_SCALAR = 0, /* one element: rows == columns == 1 */
    PBO_VECTOR = 1, /* columns elements: rows == 1 */
    PBO_FRAME = 2,  /* an image frame: rows x columns pixels, row after row */
};

/* Method results and the kernel services' negative results. */
enum pbo_status {
    PBO_OK = 0,
    PBO_ERR_INVALID = -1,   /* a bad descriptor; methods use it for their own failures */
    PBO_ERR_ABI = -2,       /* descriptor with a wrong magic or ABI version */
    PBO_ERR_NO_MEMORY = -3, /* no room for the context, state and port buffers */
    PBO_ERR_EXISTS = -4,    /* a module with this name is already registered */
};

/*
 * One port. element_size is 1 (uint8_t, e.g. a grey pixel), 2 (int16_t) or 4 (int32_t, e.g.
 * Q16.16); the buffer holds rows x columns elements, row after row, little-endian.
 */
struct pbo_port {
    char name[PBO_PORT_NAME_LEN];
    uint8_t direction;     /* enum pbo_port_direction */
    uint8_t type;          /* enum pbo_port_type */
    uint16_t element_size; /* bytes per element: 1, 2 or 4 */
    uint16_t rows;         /* 1 for a scalar and a vector */
    uint16_t columns;      /* 1 for a scalar; the elements of a vector; the pixels of a row */
};

/*
 * Built by the kernel in SRAM for one instance of a module. state points to state_size bytes
 * (NULL when state_size is 0); ports[i] is the buffer of descriptor port i (element_size * rows *
 * columns bytes) and NULL for i >= port_count. All are 8-byte aligned and zero-filled when the
 * context is built, before init. For a method call the kernel copies the instance into the task
 * window (and back afterwards), and ctx and its pointers point there: a method may write its own
 * state and buffers and its stack, nothing else. The estimator gets a context of its own, with
 * its own state and port buffers, so estimating never disturbs the running executor.
 */
struct pbo_context {
    void *state;
    void *ports[PBO_MAX_PORTS];
};

/* Every method: PBO_OK (0) on success, a negative value on error. */
typedef int32_t (*pbo_method)(struct pbo_context *ctx);

/*
 * The module descriptor: const, in section .pbo_descriptor (see PBO_DESCRIPTOR). It holds no
 * pointer other than the nine method pointers, so that the words the loader must relocate are
 * exactly the descriptor words that hold a function start address. An absent method is NULL.
 */
struct pbo_descriptor {
    uint32_t magic;       /* PBO_MAGIC */
    uint16_t abi_version; /* PBO_ABI_VERSION */
    uint16_t port_count;  /* ports[0 .. port_count-1] are used, the rest are zero */
    char name[PBO_NAME_LEN];
    uint32_t state_size; /* bytes of ctx->state the kernel allocates */
    struct pbo_port ports[PBO_MAX_PORTS];
    pbo_method init;     /* once, after the kernel built the context */
    pbo_method on;       /* when the module is switched on, before its first cycle */
    pbo_method cycle;    /* once per period while on */
    pbo_method off;      /* when the module is switched off */
    pbo_method kill;     /* once, before the kernel frees the context */
    pbo_method error;    /* after a method failed: reach a safe state */
    pbo_method clear;    /* to leave the error state: back to a clean off state */
    pbo_method evaluate; /* evaluator: right after each cycle, on the executor's context */
    pbo_method estimate; /* estimator: on demand, on its own context */
};

_Static_assert(sizeof(void *) == 4, "the module ABI is for RV32 (ilp32)");
_Static_assert(sizeof(pbo_method) == 4, "method pointers are 32-bit words");

_Static_assert(sizeof(struct pbo_port) == 20, "struct pbo_port is 20 bytes");
_Static_assert(offsetof(struct pbo_port, name) == 0, "pbo_port.name at 0");
_Static_assert(offsetof(struct pbo_port, direction) == 12, "pbo_port.direction at 12");
_Static_assert(offsetof(struct pbo_port, type) == 13, "pbo_port.type at 13");
_Static_assert(offsetof(struct pbo_port, element_size) == 14, "pbo_port.element_size at 14");
_Static_assert(offsetof(struct pbo_port, rows) == 16, "pbo_port.rows at 16");
_Static_assert(offsetof(struct pbo_port, columns) == 18, "pbo_port.columns at 18");

_Static_assert(sizeof(struct pbo_context) == 36, "struct pbo_context is 36 bytes");
_Static_assert(offsetof(struct pbo_context, state) == 0, "pbo_context.state at 0");
_Static_assert(offsetof(struct pbo_context, ports) == 4, "pbo_context.ports at 4");

_Static_assert(sizeof(struct pbo_descriptor) == 224, "struct pbo_descriptor is 224 bytes");
_Static_assert(offsetof(struct pbo_descriptor, magic) == 0, "descriptor.magic at 0");
_Static_assert(offsetof(struct pbo_descriptor, abi_version) == 4, "descriptor.abi_version at 4");
_Static_assert(offsetof(struct pbo_descriptor, port_count) == 6, "descriptor.port_count at 6");
_Static_assert(offsetof(struct pbo_descriptor, name) == 8, "descriptor.name at 8");
_Static_assert(offsetof(struct pbo_descriptor, state_size) == 24, "descriptor.state_size at 24");
_Static_assert(offsetof(struct pbo_descriptor, ports) == 28, "descriptor.ports at 28");
_Static_assert(offsetof(struct pbo_descriptor, init) == 188, "descriptor.init at 188");
_Static_assert(offsetof(struct pbo_descriptor, on) == 192, "descriptor.on at 192");
_Static_assert(offsetof(struct pbo_descriptor, cycle) == 196, "descriptor.cycle at 196");
_Static_assert(offsetof(struct pbo_descriptor, off) == 200, "descriptor.off at 200");
_Static_assert(offsetof(struct pbo_descriptor, kill) == 204, "descriptor.kill at 204");
_Static_assert(offsetof(struct pbo_descriptor, error) == 208, "descriptor.error at 208");
_Static_assert(offsetof(struct pbo_descriptor, clear) == 212, "descriptor.clear at 212");
_Static_assert(offsetof(struct pbo_descriptor, evaluate) == 216, "descriptor.evaluate at 216");
_Static_assert(offsetof(struct pbo_descriptor, estimate) == 220, "descriptor.estimate at 220");

/*
 * Kernel services, called with ecall: service number in a7, arguments in a0..a3, result in a0.
 * A bad argument is not returned as an error: it stops the method with a fault (the kernel then
 * puts the module into its error state). Bad arguments are an unknown service, a context other
 * than the running method's own, a port index >= port_count, a PORT_WRITE to an IN or CONST port,
 * a PORT_READ destination outside the task window (ctx's own memory) and the stack, a source or
 * text outside memory the module may read, and a LOG longer than 256 bytes.
 * The table in docs/module-abi.md is the reference; keep the two identical.
 */
enum pbo_service {
    /* (const struct pbo_descriptor *d) -> PBO_OK or a negative enum pbo_status; module_init only */
    PBO_SYS_REGISTER = 1,
    /* (ctx, port_index, void *dst, uint32_t len) -> bytes copied, min(len, port size); any port */
    PBO_SYS_PORT_READ = 2,
    /* (ctx, port_index, const void *src, uint32_t len) -> bytes copied; OUT and RESOURCE ports */
    PBO_SYS_PORT_WRITE = 3,
    /* () -> low 32 bits of the node's virtual time in microseconds, this call's time included */
    PBO_SYS_TIME_US = 4,
    /* (const char *text, uint32_t len) -> 0; at most 256 bytes, text need not be NUL-terminated */
    PBO_SYS_LOG = 5,
    /* (ctx, kind, index, int32_t value_milli) -> 0; kind is enum pbo_perf_kind */
    PBO_SYS_PERF_REPORT = 6,
};

/* The kind of a performance report; value_milli is the value in thousandths of its unit. */
enum pbo_perf_kind {
    PBO_PERF_FUNCTIONAL = 0,     /* how well the module does its job, e.g. an output error */
    PBO_PERF_NON_FUNCTIONAL = 1, /* the resources it costs, e.g. power in mW */
};

/* One ecall; the services ignore the arguments they do not take. */
static inline uint32_t pbo_ecall(uint32_t service, uint32_t arg0, uint32_t arg1, uint32_t arg2,
                                 uint32_t arg3)
{
    register uint32_t a0 __asm__("a0") = arg0;
    register uint32_t a1 __asm__("a1") = arg1;
    register uint32_t a2 __asm__("a2") = arg2;
    register uint32_t a3 __asm__("a3") = arg3;
    register uint32_t a7 __asm__("a7") = service;
    __asm__ volatile("ecall" : "+r"(a0) : "r"(a1), "r"(a2), "r"(a3), "r"(a7) : "memory");
    return a0;
}

static inline int32_t pbo_sys_register(const struct pbo_descriptor *d)
{
    return (int32_t)pbo_ecall(PBO_SYS_REGISTER, (uint32_t)(uintptr_t)d, 0, 0, 0);
}

static inline int32_t pbo_sys_port_read(struct pbo_context *ctx, uint32_t port_index, void *dst,
                                        uint32_t len)
{
    return (int32_t)pbo_ecall(PBO_SYS_PORT_READ, (uint32_t)(uintptr_t)ctx, port_index,
                              (uint32_t)(uintptr_t)dst, len);
}

static inline int32_t pbo_sys_port_write(struct pbo_context *ctx, uint32_t port_index,
                                         const void *src, uint32_t len)
{
    return (int32_t)pbo_ecall(PBO_SYS_PORT_WRITE, (uint32_t)(uintptr_t)ctx, port_index,
                              (uint32_t)(uintptr_t)src, len);
}

static inline uint32_t pbo_sys_time_us(void)
{
    return pbo_ecall(PBO_SYS_TIME_US, 0, 0, 0, 0);
}

/* The node's cycle counter, 64 bits: its clock in CPU cycles, one instruction a cycle, exact and
 * the same on every run (the node answers rdcycle itself: docs/module-abi.md). The difference of
 * two reads in one call is the instructions between them: a stopwatch for code. */
static inline uint64_t pbo_cycles(void)
{
    uint32_t high;
    uint32_t low;
    uint32_t again;
    do {
        __asm__ volatile("rdcycleh %0" : "=r"(high));
        __asm__ volatile("rdcycle %0" : "=r"(low));
        __asm__ volatile("rdcycleh %0" : "=r"(again));
    } while (high != again);
    return ((uint64_t)high << 32) | low;
}

static inline int32_t pbo_sys_log(const char *text, uint32_t len)
{
    return (int32_t)pbo_ecall(PBO_SYS_LOG, (uint32_t)(uintptr_t)text, len, 0, 0);
}

static inline int32_t pbo_sys_perf_report(struct pbo_context *ctx, enum pbo_perf_kind kind,
                                          uint32_t index, int32_t value_milli)
{
    return (int32_t)pbo_ecall(PBO_SYS_PERF_REPORT, (uint32_t)(uintptr_t)ctx, (uint32_t)kind,
                              index, (uint32_t)value_milli);
}

/* Logs a string literal without its NUL. */
#define PBO_LOG(literal) pbo_sys_log((literal), (uint32_t)(sizeof(literal) - 1u))

/* Marks the module's one descriptor:
 *     static const struct pbo_descriptor my_descriptor PBO_DESCRIPTOR = {...};
 */
#define PBO_DESCRIPTOR __attribute__((section(".pbo_descriptor"), used, aligned(4)))

/*
 * Defines the module's registration subroutine, module_init: the image's entry point, linked
 * first at the link base and named by the HEX file's 08 record. It only registers the descriptor;
 * the kernel then builds the context and calls init.
 */
#define PBO_MODULE(descriptor_variable)                                                            \
    void module_init(void) __attribute__((section(".text.module_init")));                          \
    void module_init(void)                                                                         \
    {                                                                                              \
        (void)pbo_sys_register(&(descriptor_variable));                                            \
    }

/*
 * Q16.16 fixed point: an int32_t holding value * 2^16, the format of the examples' ports. A
 * module may use float (soft float from libgcc, slow and some kilobytes), but the examples compute
 * in fixed point with these helpers. The rule for the Q16.16 ones: a result is rounded to nearest
 * with halves towards +infinity, floor(v + 1/2), and saturates to INT32_MIN or INT32_MAX outside
 * the int32 range; pbo_milli_from_fixed, for reports, rounds down. (Right shifts of negative
 * values are arithmetic in GCC.)
 */
#define PBO_Q16_FRACTION_BITS 16
#define PBO_Q16_ONE ((int32_t)1 << PBO_Q16_FRACTION_BITS) /* 1.0 */
#define PBO_Q16_HALF (PBO_Q16_ONE / 2)                      /* 0.5 */

/* Always inlined: the helpers are meant to cost what the arithmetic they stand for costs, and
 * pbo_milli_from_fixed needs its constant arguments folded to avoid a 64-bit division. */
#define PBO_INLINE static inline __attribute__((always_inline))

/*
 * A constant in Q16.16, e.g. PBO_Q16(2.5) or PBO_Q16(-0.1): x * 2^16 by the rule above, folded
 * by the compiler. Only for constants: a variable x would need floating point at run time.
 */
#define PBO_Q16(x)                                                                                 \
    (PBO_Q16_SCALED_(x) >= 2147483648.0    ? INT32_MAX                                             \
     : PBO_Q16_SCALED_(x) < -2147483648.0 ? INT32_MIN                                              \
                                          : (int32_t)PBO_FLOOR_(PBO_Q16_SCALED_(x)))
/* Its parts: x * 2^16 + 1/2, and floor(v) from the conversion to int64, which truncates. */
#define PBO_Q16_SCALED_(x) ((x) * 65536.0 + 0.5)
#define PBO_FLOOR_(v) ((int64_t)(v) - ((v) < (double)(int64_t)(v)))

/* A 64-bit result clamped to the int32 range. */
PBO_INLINE int32_t pbo_saturate_int32(int64_t value)
{
    if (value > INT32_MAX) {
        return INT32_MAX;
    }
    if (value < INT32_MIN) {
        return INT32_MIN;
    }
    return (int32_t)value;
}

/* n in Q16.16, saturated outside -32768..32767. */
PBO_INLINE int32_t pbo_q16_from_int(int32_t n)
{
    return pbo_saturate_int32((int64_t)n * PBO_Q16_ONE);
}

/* q rounded to an integer, floor(q / 2^16 + 1/2): bit 15 is the half to round up. */
PBO_INLINE int32_t pbo_q16_to_int(int32_t q)
{
    return (q >> PBO_Q16_FRACTION_BITS) + ((q >> (PBO_Q16_FRACTION_BITS - 1)) & 1);
}

/* a * b in Q16.16: the exact 64-bit product, rounded to nearest (halves up), saturated. */
PBO_INLINE int32_t pbo_q16_mul(int32_t a, int32_t b)
{
    return pbo_saturate_int32(((int64_t)a * b + PBO_Q16_HALF) >> PBO_Q16_FRACTION_BITS);
}

/*
 * A non-negative fixed-point magnitude with `fraction_bits` fraction bits (16 for Q16.16, 32 for
 * the exact product of two Q16.16 values), in thousandths for pbo_sys_perf_report: rounded down,
 * floor(magnitude * 1000 / 2^fraction_bits), and INT32_MAX from magnitude >= floor(INT32_MAX *
 * 2^fraction_bits / 1000) on (so INT32_MAX also stands for the one value just below it).
 * fraction_bits is a constant of at most 32; magnitude * 1000 is computed in 64 bits only below
 * that threshold, where it cannot overflow.
 */
PBO_INLINE int32_t pbo_milli_from_fixed(uint64_t magnitude, uint32_t fraction_bits)
{
    if (magnitude >= ((uint64_t)INT32_MAX << fraction_bits) / 1000u) {
        return INT32_MAX;
    }
    return (int32_t)((magnitude * 1000u) >> fraction_bits);
}

/*
 * The evaluator's cycle period and power draw. The evaluator runs right after every cycle, at the
 * cycle's rate, so the time between two evaluations is the cycle period; measuring it there
 * keeps the cycle free of service calls. A module embeds a struct pbo_timing in its state
 * (ctx->state: no static variables), calls pbo_timing_reset in init, off and clear (a pause must
 * not count as a period), and starts evaluate with pbo_measure_power:
 *
 *     const int32_t power = pbo_measure_power(&s->timing, IDLE_MILLI_MW, ENERGY_PER_CYCLE_NJ);
 *     pbo_sys_perf_report(ctx, PBO_PERF_FUNCTIONAL, 0, ...);
 *     pbo_sys_perf_report(ctx, PBO_PERF_NON_FUNCTIONAL, PBO_POWER_INDEX, power);
 */
struct pbo_timing {
    uint32_t last_cycle_us; /* node time of the latest evaluation */
    uint32_t period_us;     /* time between the two latest evaluations; 0 until two were timed */
    uint8_t timed;          /* last_cycle_us is valid */
};

_Static_assert(sizeof(struct pbo_timing) == 12, "struct pbo_timing is 12 bytes");

/* The non-functional value an evaluator reports its power draw under, in thousandths of a mW. */
#define PBO_POWER_INDEX 0u

static inline void pbo_timing_reset(struct pbo_timing *timing)
{
    timing->last_cycle_us = 0;
    timing->period_us = 0;
    timing->timed = 0;
}

/*
 * Reads the node's time, measures the period since the previous evaluation, and returns the power
 * draw in thousandths of a mW: the idle power plus energy_per_cycle_nj nJ every period_us us, i.e.
 * idle + 1000 * nJ / us, rounded down; the idle power alone until a period was measured (and for
 * a period of 0 us). First in evaluate, so the time is read at the same point of every evaluation
 * whatever the reports cost. 1000 * energy_per_cycle_nj must fit 32 bits: at most 4,294,967 nJ.
 */
PBO_INLINE int32_t pbo_measure_power(struct pbo_timing *timing, uint32_t idle_milli_mw,
                                     uint32_t energy_per_cycle_nj)
{
    const uint32_t now = pbo_sys_time_us();
    uint32_t power = idle_milli_mw;

    if (timing->timed) {
        timing->period_us = now - timing->last_cycle_us; /* unsigned: right across the wrap */
    }
    timing->last_cycle_us = now;
    timing->timed = 1;
    if (timing->period_us != 0) {
        power += 1000u * energy_per_cycle_nj / timing->period_us;
    }
    return (int32_t)power;
}

#endif /* PBO_MODULE_H */
