/*
 * abi.h - the module ABI as the kernel reads it: offsets into guest memory, not C structs.
 *
 * module_sdk/pbo_module.h is the ABI (docs/module-abi.md); it declares the descriptor with
 * pointer-sized fields and asserts that pointers are 32 bits, so it compiles only for RV32. The
 * kernel must also build on a 64-bit host for its tests, so it never overlays those structs on
 * guest memory: it reads the descriptor's little-endian fields at the offsets below through
 * guest_memory.h. abi_check.c asserts, in every RV32 build, that these numbers are the header's.
 */
#ifndef KERNEL_ABI_H
#define KERNEL_ABI_H

#define ABI_VERSION 1u
#define ABI_MAGIC 0x314F4250u /* "PBO1" as a little-endian word */
#define ABI_NAME_LEN 16u      /* bytes of the module's name field */
#define ABI_PORT_NAME_LEN 12u /* bytes of a port's name field */
#define ABI_MAX_PORTS 8u

/* struct pbo_descriptor */
#define ABI_DESCRIPTOR_SIZE 224u
#define ABI_OFFSET_MAGIC 0u
#define ABI_OFFSET_ABI_VERSION 4u
#define ABI_OFFSET_PORT_COUNT 6u
#define ABI_OFFSET_NAME 8u
#define ABI_OFFSET_STATE_SIZE 24u
#define ABI_OFFSET_PORTS 28u
#define ABI_OFFSET_METHODS 188u

/* struct pbo_port */
#define ABI_PORT_SIZE 20u
#define ABI_PORT_OFFSET_DIRECTION 12u
#define ABI_PORT_OFFSET_TYPE 13u
#define ABI_PORT_OFFSET_ELEMENT_SIZE 14u
#define ABI_PORT_OFFSET_ROWS 16u
#define ABI_PORT_OFFSET_COLUMNS 18u

/* struct pbo_context: state, then ports[8], 32-bit guest addresses */
#define ABI_CONTEXT_SIZE 36u

#define ABI_LOG_LIMIT 256u /* bytes one LOG call may pass */

/* enum pbo_port_direction */
enum port_direction { DIRECTION_IN, DIRECTION_OUT, DIRECTION_CONST, DIRECTION_RESOURCE };
#define DIRECTION_COUNT 4u

/* enum pbo_port_type */
enum port_kind { KIND_SCALAR, KIND_VECTOR, KIND_FRAME };
#define KIND_COUNT 3u

/* The descriptor's method slots, in descriptor order (pbort.code.Method). */
enum method {
    METHOD_INIT,
    METHOD_ON,
    METHOD_CYCLE,
    METHOD_OFF,
    METHOD_KILL,
    METHOD_ERROR,
    METHOD_CLEAR,
    METHOD_EVALUATE,
    METHOD_ESTIMATE,
    METHOD_COUNT
};

/* enum pbo_status: method results and REGISTER's refusals (Status in services.py) */
enum status {
    STATUS_OK = 0,
    STATUS_ERR_INVALID = -1,
    STATUS_ERR_ABI = -2,
    STATUS_ERR_NO_MEMORY = -3,
    STATUS_ERR_EXISTS = -4,
};

/* enum pbo_service: the ecall numbers in a7 */
enum service {
    SERVICE_REGISTER = 1,
    SERVICE_PORT_READ = 2,
    SERVICE_PORT_WRITE = 3,
    SERVICE_TIME_US = 4,
    SERVICE_LOG = 5,
    SERVICE_PERF_REPORT = 6,
};

/* enum pbo_perf_kind */
enum performance_kind { PERFORMANCE_FUNCTIONAL = 0, PERFORMANCE_NON_FUNCTIONAL = 1 };

/* The method names the kernel's messages use (pbort.code.Method values). */
const char *method_name(enum method method);

#endif /* KERNEL_ABI_H */
