/*
 * abi_check.c - the kernel's view of the ABI (abi.h) against the ABI itself (pbo_module.h).
 *
 * pbo_module.h compiles only where pointers are 32 bits, so the check runs in the RV32 build;
 * the host build has only the method names. A layout change in the header without the same
 * change here stops the firmware's build instead of misreading every descriptor.
 */
#include "abi.h"

#if defined(__riscv) && __riscv_xlen == 32
#include "../../module_sdk/pbo_module.h" /* relative: no include path to set up */

_Static_assert(ABI_VERSION == PBO_ABI_VERSION, "ABI version");
_Static_assert(ABI_MAGIC == PBO_MAGIC, "descriptor magic");
_Static_assert(ABI_NAME_LEN == PBO_NAME_LEN, "module name length");
_Static_assert(ABI_PORT_NAME_LEN == PBO_PORT_NAME_LEN, "port name length");
_Static_assert(ABI_MAX_PORTS == PBO_MAX_PORTS, "ports per module");
_Static_assert(ABI_DESCRIPTOR_SIZE == sizeof(struct pbo_descriptor), "descriptor size");
_Static_assert(ABI_OFFSET_MAGIC == offsetof(struct pbo_descriptor, magic), "magic");
_Static_assert(ABI_OFFSET_ABI_VERSION == offsetof(struct pbo_descriptor, abi_version), "abi");
_Static_assert(ABI_OFFSET_PORT_COUNT == offsetof(struct pbo_descriptor, port_count), "count");
_Static_assert(ABI_OFFSET_NAME == offsetof(struct pbo_descriptor, name), "name");
_Static_assert(ABI_OFFSET_STATE_SIZE == offsetof(struct pbo_descriptor, state_size), "state");
_Static_assert(ABI_OFFSET_PORTS == offsetof(struct pbo_descriptor, ports), "ports");
_Static_assert(ABI_OFFSET_METHODS == offsetof(struct pbo_descriptor, init), "methods");
_Static_assert(ABI_OFFSET_METHODS + 4u * METHOD_ESTIMATE ==
                   offsetof(struct pbo_descriptor, estimate),
               "method order");
_Static_assert(ABI_PORT_SIZE == sizeof(struct pbo_port), "port size");
_Static_assert(ABI_PORT_OFFSET_DIRECTION == offsetof(struct pbo_port, direction), "direction");
_Static_assert(ABI_PORT_OFFSET_TYPE == offsetof(struct pbo_port, type), "type");
_Static_assert(ABI_PORT_OFFSET_ELEMENT_SIZE == offsetof(struct pbo_port, element_size), "size");
_Static_assert(ABI_PORT_OFFSET_ROWS == offsetof(struct pbo_port, rows), "rows");
_Static_assert(ABI_PORT_OFFSET_COLUMNS == offsetof(struct pbo_port, columns), "columns");
_Static_assert(ABI_CONTEXT_SIZE == sizeof(struct pbo_context), "context size");
_Static_assert((int)STATUS_ERR_EXISTS == (int)PBO_ERR_EXISTS, "status codes");
_Static_assert((int)STATUS_ERR_NO_MEMORY == (int)PBO_ERR_NO_MEMORY, "status codes");
_Static_assert((int)STATUS_ERR_ABI == (int)PBO_ERR_ABI, "status codes");
_Static_assert((int)STATUS_ERR_INVALID == (int)PBO_ERR_INVALID, "status codes");
_Static_assert((int)SERVICE_PERF_REPORT == (int)PBO_SYS_PERF_REPORT, "service numbers");
_Static_assert((int)SERVICE_LOG == (int)PBO_SYS_LOG, "service numbers");
_Static_assert((int)SERVICE_TIME_US == (int)PBO_SYS_TIME_US, "service numbers");
_Static_assert((int)SERVICE_PORT_WRITE == (int)PBO_SYS_PORT_WRITE, "service numbers");
_Static_assert((int)SERVICE_PORT_READ == (int)PBO_SYS_PORT_READ, "service numbers");
_Static_assert((int)SERVICE_REGISTER == (int)PBO_SYS_REGISTER, "service numbers");
_Static_assert((int)DIRECTION_RESOURCE == (int)PBO_PORT_RESOURCE, "port directions");
_Static_assert((int)KIND_FRAME == (int)PBO_FRAME, "port types");
#endif

const char *method_name(enum method method)
{
    static const char *const names[METHOD_COUNT] = {
        "init", "on", "cycle", "off", "kill", "error", "clear", "evaluate", "estimate",
    };
    return method < METHOD_COUNT ? names[method] : "?";
}
