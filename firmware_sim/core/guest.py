"""The guest back end of the kernel contract (`pbort.code`): modules that run as RV32IM code.

A module arrives as an image in flash; its init subroutine hands its descriptor to the kernel
with the REGISTER ecall, which `Registrar` answers after checking the descriptor
(`register_module` runs the whole exchange for the loader). `GuestModule` is the registered
module as the kernel sees it (`ModuleCode`), and `GuestInstance` one instance of it (`Instance`):
the executor, or an estimator with its own state and ports.

An instance owns one area in SRAM: the context (`struct pbo_context`), the state and the port
buffers, each 8-byte aligned (docs/module-abi.md). Guests may not write SRAM. For a call the whole
area is copied to the end of the task window, the only memory besides the stack a guest may
write, and copied back afterwards; the context always points into the window. So a module can
write only its own state and ports, and a write past its area runs off the end of the window and
faults (docs/memory-map.md).
"""

from __future__ import annotations

import struct
from collections.abc import Container
from dataclasses import dataclass

from firmware_sim.core.cpu import Cpu
from firmware_sim.core.repeated_calls import RepeatedCalls
from firmware_sim.core.services import (
    MILLI,
    Service,
    Status,
    check_guest_readable,
    check_guest_writable,
    check_log_length,
)
from firmware_sim.core.source_lines import SourceLines
from firmware_sim.core.sram import SramAllocator, align_up
from firmware_sim.errors import RegistrationError, ServiceFault
from hexmigrate import descriptor as abi
from hexmigrate.errors import AbiMismatchError, DescriptorError
from pbort.code import CallResult, Method, PerformanceKind, Role, Services
from pbort.ports import Direction, PortKind, PortSpec, PortValue

_CONTEXT = struct.Struct(f"<{1 + abi.MAX_PORTS}I")  # struct pbo_context: state, ports[8]
CONTEXT_SIZE = _CONTEXT.size  # 36 bytes
DEFAULT_BUDGET = 100_000  # instructions per method call: 1 ms at 100 MHz
_DTYPES = {1: "u1", 2: "<i2", 4: "<i4"}  # element_size -> numpy dtype, per the ABI's port table
_WRITABLE_PORTS = frozenset({Direction.OUT, Direction.RESOURCE})


def port_spec(port: abi.PortSpec) -> PortSpec:
    """The kernel's view of a descriptor port: a scalar has shape (), a vector (columns,), a
    frame (rows, columns)."""
    kind = PortKind(port.type)
    shape = {
        PortKind.SCALAR: (),
        PortKind.VECTOR: (port.columns,),
        PortKind.FRAME: (port.rows, port.columns),
    }[kind]
    return PortSpec(port.name, Direction(port.direction), kind, _DTYPES[port.element_size], shape)


@dataclass(frozen=True)
class AreaLayout:
    """Where the context, the state and each port buffer sit in an instance's area.

    Offsets are from the area's start; `state` is None when the module has no state; `size` is
    the whole area, a multiple of 8.
    """

    state: int | None
    ports: tuple[int, ...]
    size: int

    @classmethod
    def of(cls, descriptor: abi.Descriptor) -> AreaLayout:
        """The layout for a descriptor: context, state, then the ports in descriptor order."""
        offset = align_up(CONTEXT_SIZE)
        state = None
        if descriptor.state_size:
            state, offset = offset, align_up(offset + descriptor.state_size)
        ports = []
        for port in descriptor.ports:
            ports.append(offset)
            offset = align_up(offset + port.size_bytes)
        return cls(state, tuple(ports), offset)

    def context(self, base: int) -> bytes:
        """`struct pbo_context` for an area at `base`: NULL for no state and for unused ports."""
        state = 0 if self.state is None else base + self.state
        ports = [base + offset for offset in self.ports]
        return _CONTEXT.pack(state, *ports, *[0] * (abi.MAX_PORTS - len(ports)))


class _KernelServices:
    """What every guest call may use (TIME_US, LOG); the other services refuse by default.

    Subclasses answer the services that make sense while they are attached: the registrar
    REGISTER, an instance the port and performance services.
    """

    def __init__(self, cpu: Cpu, kernel: Services, label: str) -> None:
        self._cpu = cpu
        self._kernel = kernel
        self._label = label

    def _refuse(self, service: Service) -> ServiceFault:
        return ServiceFault(f"{service.name}: not available to {self._label}")

    def register(self, descriptor: int) -> int:
        raise self._refuse(Service.REGISTER)

    def port_read(self, context: int, port: int, destination: int, length: int) -> int:
        raise self._refuse(Service.PORT_READ)

    def port_write(self, context: int, port: int, source: int, length: int) -> int:
        raise self._refuse(Service.PORT_WRITE)

    def perf_report(self, context: int, kind: int, index: int, value_milli: int) -> int:
        raise self._refuse(Service.PERF_REPORT)

    def time_us(self) -> int:
        """The kernel's time plus what this call has run so far, rounded to whole µs."""
        seconds = self._kernel.now() + self._cpu.instructions / self._cpu.frequency_hz
        return round(seconds * 1e6) & 0xFFFF_FFFF

    def log(self, text: int, length: int) -> int:
        check_log_length(length)
        check_guest_readable(self._cpu.memory, text, length, "LOG text")
        self._kernel.log(self._cpu.read(text, length).decode("utf-8", errors="replace"))
        return 0


class Registrar(_KernelServices):
    """Answers REGISTER while the init subroutine of a module just written to flash runs.

    The descriptor must lie inside the module's image, decode under this ABI, name the module
    (not one in `taken`) and its ports uniquely, point its methods at 4-byte aligned addresses
    inside the image, and need an area that fits in the task window and in free SRAM. Afterwards
    `descriptor` holds it, or `refusal` says why REGISTER returned a negative status.
    """

    def __init__(
        self,
        cpu: Cpu,
        sram: SramAllocator,
        image_base: int,
        image_size: int,
        kernel: Services,
        taken: Container[str] = frozenset(),
    ) -> None:
        image = f"module image at 0x{image_base:08X}..0x{image_base + image_size - 1:08X}"
        super().__init__(cpu, kernel, f"the init subroutine of the {image}")
        self._sram = sram
        self._image = range(image_base, image_base + image_size)
        self._image_text = image
        self._taken = taken
        self.descriptor: abi.Descriptor | None = None
        self.refusal: str | None = None

    def register(self, descriptor: int) -> int:
        try:
            self.descriptor = self._accept(descriptor)
        except _Refused as refused:
            self.refusal = f"REGISTER refused ({refused.status.name}): {refused}"
            return refused.status
        return Status.OK

    def _accept(self, address: int) -> abi.Descriptor:
        if self.descriptor is not None:
            raise _Refused(Status.ERR_EXISTS, f"{self.descriptor.name!r} is already registered")
        if address not in self._image or address + abi.SIZE > self._image.stop:
            raise _Refused(
                Status.ERR_INVALID,
                f"expected the {abi.SIZE}-byte descriptor inside the {self._image_text}, "
                f"got it at 0x{address:08X}",
            )
        try:
            descriptor = abi.Descriptor.decode(self._cpu.read(address, abi.SIZE))
        except AbiMismatchError as error:
            raise _Refused(Status.ERR_ABI, str(error)) from None
        except DescriptorError as error:
            raise _Refused(Status.ERR_INVALID, str(error)) from None
        self._check_names(descriptor)
        self._check_methods(descriptor)
        self._check_size(descriptor)
        return descriptor

    def _check_names(self, descriptor: abi.Descriptor) -> None:
        if not descriptor.name:
            raise _Refused(Status.ERR_INVALID, "expected a module name, got an empty one")
        if descriptor.name in self._taken:
            raise _Refused(Status.ERR_EXISTS, f"a module {descriptor.name!r} is already loaded")
        names = [port.name for port in descriptor.ports]
        if "" in names or len(set(names)) != len(names):
            raise _Refused(
                Status.ERR_INVALID,
                f"module {descriptor.name!r}: expected distinct, non-empty port names, got {names}",
            )

    def _check_methods(self, descriptor: abi.Descriptor) -> None:
        for method, address in descriptor.methods.items():
            if address and (address not in self._image or address % 4):
                raise _Refused(
                    Status.ERR_INVALID,
                    f"module {descriptor.name!r}: expected method {method} at a 4-byte aligned "
                    f"address inside the {self._image_text}, got 0x{address:08X}",
                )

    def _check_size(self, descriptor: abi.Descriptor) -> None:
        size = AreaLayout.of(descriptor).size
        room = min(self._cpu.memory.window.size, self._sram.largest_free)
        if size > room:
            raise _Refused(
                Status.ERR_NO_MEMORY,
                f"module {descriptor.name!r}: needs a {size}-byte area, but the task window holds "
                f"{self._cpu.memory.window.size} bytes and the largest free SRAM block is "
                f"{self._sram.largest_free} bytes",
            )


class _Refused(Exception):
    """Why REGISTER returns a negative status."""

    def __init__(self, status: Status, reason: str) -> None:
        super().__init__(reason)
        self.status = status


def register_module(
    cpu: Cpu,
    sram: SramAllocator,
    image_base: int,
    image_size: int,
    init: int,
    kernel: Services,
    *,
    taken: Container[str] = frozenset(),
    budget: int = DEFAULT_BUDGET,
) -> abi.Descriptor:
    """Run a loaded module's init subroutine (at `init`, relocated) and return its descriptor.

    Raises RegistrationError when the subroutine faults, REGISTER refused the descriptor, or the
    subroutine returned without registering.
    """
    registrar = Registrar(cpu, sram, image_base, image_size, kernel, taken)
    code = range(image_base, image_base + image_size)
    run = cpu.call(init, (), budget, registrar, code, at=kernel.now())
    where = f"module image at 0x{image_base:08X}, init subroutine at 0x{init:08X}"
    if run.fault is not None:
        raise RegistrationError(f"{where}: {run.fault}")
    if registrar.descriptor is None:
        raise RegistrationError(
            f"{where}: {registrar.refusal or 'returned without calling REGISTER'}"
        )
    return registrar.descriptor


class GuestModule:
    """A registered guest module (`pbort.code.ModuleCode`): descriptor, ports, instances.

    `descriptor` is the one REGISTER accepted, read from flash after relocation, so its method
    addresses are where the code is; the image is the `image_size` bytes from `load_address`,
    and its methods may fetch instructions nowhere else. Each method call may run at most
    `budget` instructions.
    """

    def __init__(
        self,
        cpu: Cpu,
        sram: SramAllocator,
        descriptor: abi.Descriptor,
        load_address: int,
        image_size: int,
        *,
        budget: int = DEFAULT_BUDGET,
    ) -> None:
        self.cpu = cpu
        self.sram = sram
        self.descriptor = descriptor
        self.load_address = load_address
        self.image = range(load_address, load_address + image_size)
        self.budget = budget
        self.layout = AreaLayout.of(descriptor)
        if self.layout.size > cpu.memory.window.size:
            raise ValueError(
                f"{self.label}: expected an area of at most {cpu.memory.window.size} bytes "
                f"(the task window), got {self.layout.size}"
            )
        self._ports = tuple(port_spec(port) for port in descriptor.ports)
        # Byte sizes, kept apart: PortSpec.size_bytes asks numpy, too slow for every ecall.
        self.port_sizes = tuple(port.size_bytes for port in descriptor.ports)
        self.source: SourceLines | None = None
        """The module's ELF, when the node has the build that was installed."""
        self.link_base = load_address
        """Where the image was linked, as its module file says (the node sets it)."""

    def where(self, address: int) -> str | None:
        """'gain_cycle (gain.c:42)' for an address of this module's code, when its ELF is known."""
        if self.source is None or address not in self.image:
            return None
        location = self.source.locate(address - self.load_address + self.source.image.link_base)
        return None if location is None else str(location)

    @property
    def name(self) -> str:
        """The module's name, from its descriptor."""
        return self.descriptor.name

    @property
    def label(self) -> str:
        """The module and where it is, for messages."""
        return f"module {self.name!r} at 0x{self.load_address:08X}"

    @property
    def ports(self) -> tuple[PortSpec, ...]:
        """The ports in descriptor order."""
        return self._ports

    def entry(self, method: Method) -> int:
        """The address of a method's code, 0 when the module has none."""
        return self.descriptor.methods[method.value]

    def implements(self, method: Method) -> bool:
        """True when the descriptor has a pointer for `method`."""
        return self.entry(method) != 0

    def instantiate(self, role: Role, services: Services) -> GuestInstance:
        """A new instance with a zero-filled area in SRAM; raises OutOfSramError when full."""
        return GuestInstance(self, role, services)


class GuestInstance:
    """One instance of a guest module (`pbort.code.Instance`): an area in SRAM and its calls."""

    def __init__(self, module: GuestModule, role: Role, services: Services) -> None:
        self.module = module
        self.role = role
        self._cpu = module.cpu
        layout = module.layout
        self._size = layout.size
        self.area = module.sram.allocate(layout.size, f"{module.label} ({role.value})")
        self.window = self._cpu.memory.window.end - layout.size  # the area's place in a call
        self._context = layout.context(self.window)
        self._ports = {
            spec.name: (spec, offset, size)
            for spec, offset, size in zip(
                module.ports, layout.ports, module.port_sizes, strict=True
            )
        }
        # An estimator's repeated calls are replayed (firmware_sim/core/repeated_calls.py).
        self._repeats = RepeatedCalls(services) if role is Role.ESTIMATOR else None
        if self._repeats is not None:
            services = self._repeats.services
        self._services = _InstanceServices(module, self.window, services, self.label)
        self._now = services.now  # the kernel's clock: where each call's cycle counter starts
        self._released = False
        self._cpu.write(self.area, self._context + bytes(layout.size - CONTEXT_SIZE))

    @property
    def label(self) -> str:
        """The module, where it is, and this instance's role, for messages."""
        return f"{self.module.label} ({self.role.value})"

    def put(self, port: str, value: PortValue) -> None:
        """Write a port's value into its buffer in SRAM, as the guest will see it."""
        spec, offset, _ = self._port(port)
        try:
            data = spec.encode(value)
        except (ValueError, TypeError, OverflowError) as error:
            raise ValueError(f"{self.label}, port {port!r}: {error}") from None
        self._cpu.write(self.area + offset, data)

    def get(self, port: str) -> PortValue:
        """A port's value from its buffer in SRAM (outputs as the last call left them)."""
        spec, offset, size = self._port(port)
        return spec.decode(self._cpu.read(self.area + offset, size))

    def call(self, method: Method) -> CallResult:
        """Run one method in the task window; an absent method returns 0 at once."""
        self._check_live()
        entry = self.module.entry(method)
        if not entry:
            return CallResult()
        repeats = self._repeats
        if repeats is None:
            return self._run(method, entry)
        key = repeats.key(method, self._cpu.read(self.area, self._size))
        replayed = repeats.replay(key)
        if replayed is not None:
            area_after, result = replayed
            self._cpu.write(self.area, area_after)
            return result
        repeats.start()
        result = self._run(method, entry)
        repeats.finish(key, self._cpu.read(self.area, self._size), result)
        return result

    def _run(self, method: Method, entry: int) -> CallResult:
        """Run the method on the CPU: the area into the task window, the call, and back."""
        cpu, body = self._cpu, self._size - CONTEXT_SIZE
        # A fresh context every call: the guest may have overwritten its own in the window.
        cpu.write(self.window, self._context)
        cpu.copy(self.window + CONTEXT_SIZE, self.area + CONTEXT_SIZE, body)
        module = self.module
        run = cpu.call(
            entry, (self.window,), module.budget, self._services, module.image, at=self._now()
        )
        cpu.copy(self.area + CONTEXT_SIZE, self.window + CONTEXT_SIZE, body)
        if run.fault is not None:
            where = None if run.pc is None else module.where(run.pc)
            place = f" in {where}" if where is not None else ""
            fault = f"{self.label}, {method.value}: {run.fault}{place}"
            return CallResult(run.status, fault, run.duration, run.instructions)
        where = module.where(entry) if run.status != 0 else None
        return CallResult(run.status, None, run.duration, run.instructions, where)

    def release(self) -> None:
        """Free the area in SRAM; the instance cannot be used afterwards (a second release is a
        no-op)."""
        if not self._released:
            self._released = True
            self.module.sram.free(self.area)

    def _port(self, name: str) -> tuple[PortSpec, int, int]:
        self._check_live()
        try:
            return self._ports[name]
        except KeyError:
            raise KeyError(
                f"{self.label}: expected one of the ports {list(self._ports)}, got {name!r}"
            ) from None

    def _check_live(self) -> None:
        if self._released:
            raise RuntimeError(f"{self.label}: the instance was released")


class _InstanceServices(_KernelServices):
    """The services of one instance's method calls: ports, performance reports, time, log.

    `window` is the instance's area in the task window while it runs: its context address and
    the base of its port buffers there.
    """

    def __init__(self, module: GuestModule, window: int, kernel: Services, label: str) -> None:
        super().__init__(module.cpu, kernel, label)
        self._module = module
        self._window = window

    def port_read(self, context: int, port: int, destination: int, length: int) -> int:
        spec, buffer, size = self._port(context, port, Service.PORT_READ)
        count = min(length, size)
        what = f"PORT_READ of port {port} ({spec.name!r}) into its destination"
        check_guest_writable(self._cpu.memory, destination, count, what)
        self._cpu.copy(destination, buffer, count)
        return count

    def port_write(self, context: int, port: int, source: int, length: int) -> int:
        spec, buffer, size = self._port(context, port, Service.PORT_WRITE)
        if spec.direction not in _WRITABLE_PORTS:
            raise ServiceFault(
                f"PORT_WRITE: expected an OUT or RESOURCE port, got port {port} ({spec.name!r}) "
                f"of direction {spec.direction.name}"
            )
        count = min(length, size)
        what = f"PORT_WRITE of port {port} ({spec.name!r}) from its source"
        check_guest_readable(self._cpu.memory, source, count, what)
        self._cpu.copy(buffer, source, count)
        return count

    def perf_report(self, context: int, kind: int, index: int, value_milli: int) -> int:
        self._check_context(context, Service.PERF_REPORT)
        try:
            performance = PerformanceKind(kind)
        except ValueError:
            raise ServiceFault(
                f"PERF_REPORT: expected kind {PerformanceKind.FUNCTIONAL.value} (functional) or "
                f"{PerformanceKind.NON_FUNCTIONAL.value} (non-functional), got {kind}"
            ) from None
        self._kernel.report(performance, index, value_milli / MILLI)
        return 0

    def _check_context(self, context: int, service: Service) -> None:
        """Only the running instance's own context is valid: no other is in the window."""
        if context != self._window:
            raise ServiceFault(
                f"{service.name}: expected the context 0x{self._window:08X} of {self._label}, "
                f"got 0x{context:08X}"
            )

    def _port(self, context: int, index: int, service: Service) -> tuple[PortSpec, int, int]:
        """The spec of port `index`, its buffer's address in the window and its size."""
        self._check_context(context, service)
        ports = self._module.ports
        if index >= len(ports):
            raise ServiceFault(
                f"{service.name}: expected a port index below {len(ports)}, got {index}"
            )
        module = self._module
        return ports[index], self._window + module.layout.ports[index], module.port_sizes[index]
