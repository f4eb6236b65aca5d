"""The kernel services a guest reaches with `ecall`, and the checks on what it passes to them.

Service number in a7, arguments in a0..a3, result in a0 (docs/module-abi.md, "Kernel services";
the numbers are `enum pbo_service` in pbo_module.h). `Cpu` decodes the registers and calls
`dispatch`, which calls one method of a `GuestServices` object chosen by whoever started the
call: the registrar while a module's init subroutine runs, an instance's services while one of its
methods runs.

A guest that passes a bad argument (an unknown service, a context that is not its own, a port
index out of range, a pointer to memory it may not use) has broken the ABI: the service raises
`ServiceFault` and the call ends with a fault, which puts the module into its error state, instead
of returning a status the module might ignore.
"""

from __future__ import annotations

from enum import IntEnum
from typing import Protocol

from firmware_sim.core.memory_map import MemoryMap, Permission
from firmware_sim.errors import ServiceFault

LOG_LIMIT = 256  # bytes a single LOG call may pass: a bad length must not flood the kernel
MILLI = 1000  # PERF_REPORT values are in thousandths of their unit


class Service(IntEnum):
    """The service numbers, as `enum pbo_service` in pbo_module.h."""

    REGISTER = 1
    PORT_READ = 2
    PORT_WRITE = 3
    TIME_US = 4
    LOG = 5
    PERF_REPORT = 6


DESCRIPTIONS: dict[Service, str] = {
    Service.REGISTER: "(descriptor) -> PBO_OK or a negative pbo_status: only from a module's "
    "init subroutine",
    Service.PORT_READ: "(ctx, port, dst, len) -> bytes copied, min(len, port size): dst in the "
    "window or stack",
    Service.PORT_WRITE: "(ctx, port, src, len) -> bytes copied, min(len, port size): OUT and "
    "RESOURCE ports",
    Service.TIME_US: "() -> the low 32 bits of the node's virtual time in µs, this call's "
    "instructions included",
    Service.LOG: "(text, len) -> 0: at most LOG_LIMIT bytes of text, which need not end in NUL",
    Service.PERF_REPORT: "(ctx, kind, index, value_milli) -> 0: a performance value in "
    "thousandths of its unit",
}
"""What each service takes and gives (a7 = number, a0..a3 = arguments, a0 = result)."""


_BY_NUMBER = {service.value: service for service in Service}  # faster than Service(number)


class Status(IntEnum):
    """Method results and REGISTER's negative results, as `enum pbo_status` in pbo_module.h."""

    OK = 0
    ERR_INVALID = -1
    """A bad descriptor or argument (methods return it for their own failures too)."""
    ERR_ABI = -2
    """REGISTER: a descriptor with a wrong magic or ABI version."""
    ERR_NO_MEMORY = -3
    """REGISTER: the module's area does not fit in the task window or in free SRAM."""
    ERR_EXISTS = -4
    """REGISTER: a module of this name is already registered (or this one registered twice)."""


class GuestServices(Protocol):
    """One method per service; arguments are the raw 32-bit register values (unsigned)."""

    def register(self, descriptor: int) -> int:
        """Service REGISTER."""
        ...

    def port_read(self, context: int, port: int, destination: int, length: int) -> int:
        """Service PORT_READ."""
        ...

    def port_write(self, context: int, port: int, source: int, length: int) -> int:
        """Service PORT_WRITE."""
        ...

    def time_us(self) -> int:
        """Service TIME_US."""
        ...

    def log(self, text: int, length: int) -> int:
        """Service LOG."""
        ...

    def perf_report(self, context: int, kind: int, index: int, value_milli: int) -> int:
        """Service PERF_REPORT; `value_milli` is already signed."""
        ...


def signed32(value: int) -> int:
    """A 32-bit register value read as a signed integer."""
    value &= 0xFFFF_FFFF
    return value - (1 << 32) if value & 0x8000_0000 else value


def dispatch(services: GuestServices, number: int, a0: int, a1: int, a2: int, a3: int) -> int:
    """Run service `number` (from a7) with the argument registers; returns the value for a0."""
    service = _BY_NUMBER.get(number)
    if service is None:
        raise ServiceFault(
            f"unknown service {number} in a7: expected {Service.REGISTER}..{max(Service)}"
        )
    if service is Service.PORT_READ:
        return services.port_read(a0, a1, a2, a3)
    if service is Service.PORT_WRITE:
        return services.port_write(a0, a1, a2, a3)
    if service is Service.TIME_US:
        return services.time_us()
    if service is Service.LOG:
        return services.log(a0, a1)
    if service is Service.PERF_REPORT:
        return services.perf_report(a0, a1, a2, signed32(a3))
    return services.register(a0)


def check_guest_writable(memory: MemoryMap, address: int, length: int, what: str) -> None:
    """Refuse a buffer the guest could not write itself: the kernel's writes bypass protection.

    Only the task window and the stack qualify; otherwise a guest could have the kernel write to
    flash, to other modules' areas in SRAM or to the kernel page on its behalf. An empty buffer
    is never used, so any pointer will do.
    """
    region = memory.region_at(address, length)
    if length and (region is None or Permission.WRITE not in region.guest):
        raise ServiceFault(
            f"{what}: expected {length} bytes at 0x{address:08X} inside the task window or the "
            f"stack, got {_where(memory, address, length)}"
        )


def check_guest_readable(memory: MemoryMap, address: int, length: int, what: str) -> None:
    """Refuse a non-empty buffer that is not inside one mapped region the guest may read."""
    region = memory.region_at(address, length)
    if length and (region is None or Permission.READ not in region.guest):
        raise ServiceFault(
            f"{what}: expected {length} bytes at 0x{address:08X} inside guest-readable memory, "
            f"got {_where(memory, address, length)}"
        )


def check_log_length(length: int) -> None:
    """Refuse a LOG longer than LOG_LIMIT: most likely a garbage length, not a message."""
    if length > LOG_LIMIT:
        raise ServiceFault(f"LOG: expected at most {LOG_LIMIT} bytes of text, got {length}")


def _where(memory: MemoryMap, address: int, length: int) -> str:
    """Where a refused buffer lies, for the fault text."""
    first, last = memory.describe(address), memory.describe(address + max(length, 1) - 1)
    return f"a buffer in {first}" if first == last else f"a buffer from {first} into {last}"
