"""Guest modules on the emulated node: registration, instances, ports, services and isolation.

The SDK's examples are loaded the way the node's loader will load them: the image relocated to a
flash address, written there, and its init subroutine run to register the descriptor.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from firmware_sim.core.cpu import Cpu
from firmware_sim.core.guest import (
    CONTEXT_SIZE,
    AreaLayout,
    GuestInstance,
    GuestModule,
    Registrar,
    RegistrationError,
    register_module,
)
from firmware_sim.core.memory_map import FLASH_BASE, SRAM_BASE, WINDOW_BASE, MemoryMap
from firmware_sim.core.services import Status
from firmware_sim.core.sram import SramAllocator
from firmware_sim.errors import OutOfSramError
from hexmigrate import descriptor as abi
from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from module_sdk.build import ModuleBuild, build_module
from pbort.code import CallResult, Method, PerformanceKind, Role, Services
from pbort.ports import Direction, PortKind

Q16 = 1 << 16
SECOND_ADDRESS = FLASH_BASE + 0x2300  # a second, block-aligned load address

# A module that exercises frame and vector ports and, on request (its constant port `mode`),
# misuses memory and the kernel services in every way the node must stop.
PROBE_SOURCE = """\
#include "pbo_module.h"

enum { PORT_MODE, PORT_IMAGE, PORT_SUMS, PORT_CALLS, PORT_COUNT };

struct probe_state { int32_t calls; };

static int32_t probe_init(struct pbo_context *ctx)
{
    (void)ctx;
    return PBO_OK;
}

static int32_t misuse(struct pbo_context *ctx, int32_t mode)
{
    switch (mode) {
    case 1: return pbo_sys_port_read(ctx, PORT_MODE, (void *)0x20000000u, 4);
    case 2: return pbo_sys_port_write(ctx, PORT_MODE, &mode, sizeof mode);
    case 3: return pbo_sys_port_read(ctx, 9, &mode, sizeof mode);
    case 4: return pbo_sys_port_read((struct pbo_context *)((uintptr_t)ctx + 4), 0, &mode, 4);
    case 5: *(volatile int32_t *)0x08000000u = mode; return PBO_OK;
    case 6: *(volatile int32_t *)0x20000000u = mode; return PBO_OK;
    case 7: ((volatile uint8_t *)ctx->ports[PORT_CALLS])[8] = 1; return PBO_OK;
    case 8: return pbo_sys_log("too long", 1000);
    case 9: for (;;) { __asm__ volatile(""); }
    case 10: return pbo_sys_register(0);
    case 11: return pbo_sys_perf_report(ctx, 7, 0, 0);
    case 12: return pbo_sys_port_write(ctx, PORT_CALLS, (const void *)0x40000000u, 4);
    default: return PBO_ERR_INVALID;
    }
}

/* Mode 0: column sums of the frame, and how many cycles this instance ran. */
static int32_t probe_cycle(struct pbo_context *ctx)
{
    struct probe_state *s = ctx->state;
    const uint8_t *image = ctx->ports[PORT_IMAGE];
    int16_t *sums = ctx->ports[PORT_SUMS];
    int32_t mode = *(const int32_t *)ctx->ports[PORT_MODE];

    s->calls++;
    if (mode != 0) {
        return misuse(ctx, mode);
    }
    for (uint32_t column = 0; column < COLUMNS; column++) {
        int32_t sum = 0;
        for (uint32_t row = 0; row < ROWS; row++) {
            sum += image[row * COLUMNS + column];
        }
        sums[column] = (int16_t)sum;
    }
    return pbo_sys_port_write(ctx, PORT_CALLS, &s->calls, sizeof s->calls) == 4 ? PBO_OK
                                                                                 : PBO_ERR_INVALID;
}

static const struct pbo_descriptor probe_descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC,
    .abi_version = PBO_ABI_VERSION,
    .port_count = PORT_COUNT,
    .name = "probe",
    .state_size = sizeof(struct probe_state),
    .ports = {
        [PORT_MODE] = {"mode", PBO_PORT_CONST, PBO_SCALAR, 4, 1, 1},
        [PORT_IMAGE] = {"image", PBO_PORT_IN, PBO_FRAME, 1, ROWS, COLUMNS},
        [PORT_SUMS] = {"sums", PBO_PORT_OUT, PBO_VECTOR, 2, 1, COLUMNS},
        [PORT_CALLS] = {"calls", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1},
    },
    .init = probe_init,
    .cycle = probe_cycle,
};

PBO_MODULE(probe_descriptor)
"""


def build_probe(directory: Path, rows: int, columns: int) -> ModuleBuild:
    source = directory / "probe.c"
    source.write_text(f"#define ROWS {rows}u\n#define COLUMNS {columns}u\n{PROBE_SOURCE}")
    return build_module(source, directory / "out")


@pytest.fixture(scope="module")
def probe(tmp_path_factory: pytest.TempPathFactory) -> ModuleBuild:
    return build_probe(tmp_path_factory.mktemp("probe"), 3, 5)


@dataclass
class Kernel:
    """The kernel side of `pbort.code.Services`, recording what instances report and log."""

    time: float = 0.0
    reports: list[tuple[PerformanceKind, int, float]] = field(default_factory=list)
    logs: list[str] = field(default_factory=list)

    def services(self) -> Services:
        return Services(
            report=lambda kind, index, value: self.reports.append((kind, index, value)),
            now=lambda: self.time,
            log=self.logs.append,
        )


@dataclass
class Node:
    """A CPU, its SRAM allocator and a recording kernel: what the node's loader will hold."""

    cpu: Cpu
    sram: SramAllocator = field(init=False)
    kernel: Kernel = field(default_factory=Kernel)

    def __post_init__(self) -> None:
        self.sram = SramAllocator(self.cpu.memory.sram.base, self.cpu.memory.sram.size)

    def install(self, image: ModuleImage, address: int, data: bytes | None = None) -> int:
        """Write the relocated image (or `data`) to flash; returns its init address."""
        data = image.relocate(address) if data is None else data
        self.cpu.write(address, data)
        return image.init - image.link_base + address

    def register(self, image: ModuleImage, address: int, **options: object) -> abi.Descriptor:
        init = self.install(image, address)
        return register_module(
            self.cpu, self.sram, address, image.size, init, self.kernel.services(), **options
        )

    def load(self, elf: Path, address: int = FLASH_BASE, budget: int = 100_000) -> GuestModule:
        image = image_from_elf(elf)
        descriptor = self.register(image, address)
        return GuestModule(self.cpu, self.sram, descriptor, address, image.size, budget=budget)

    def instance(self, module: GuestModule, role: Role = Role.EXECUTOR) -> GuestInstance:
        return module.instantiate(role, self.kernel.services())


@pytest.fixture
def node() -> Iterator[Node]:
    with Cpu() as cpu:
        yield Node(cpu)


Step = tuple[str, CallResult, int]  # method, its result, the output y afterwards


def run_scenario(node: Node, module: GuestModule) -> tuple[list[Step], Kernel]:
    """Drive one executor through its whole life cycle, recording everything observable."""
    instance = node.instance(module)
    steps: list[Step] = []

    def call(method: Method) -> None:
        result = instance.call(method)
        steps.append((method.value, result, instance.get("y")))

    call(Method.INIT)
    call(Method.ON)  # gain refuses: k is not configured yet
    if any(port.name == "k" for port in module.ports):
        instance.put("k", round(2.5 * Q16))
        call(Method.ON)
    for x in (1.0, -3.25, 100.0, 0.5, 30000.0, 2.0):
        node.kernel.time += 1e-3
        instance.put("x", round(x * Q16))
        call(Method.CYCLE)
        call(Method.EVALUATE)
    call(Method.ERROR)
    call(Method.CLEAR)
    call(Method.OFF)
    call(Method.KILL)
    instance.release()
    return steps, node.kernel


def test_examples_run_alike_at_two_load_addresses(example: ModuleBuild) -> None:
    runs = []
    entries = []
    for address in (FLASH_BASE, SECOND_ADDRESS):
        with Cpu() as cpu:
            node = Node(cpu)
            module = node.load(example.elf, address)
            entries.append([module.entry(method) for method in Method])
            runs.append(run_scenario(node, module))
    assert [second - first for first, second in zip(*entries, strict=True)] == [
        SECOND_ADDRESS - FLASH_BASE
    ] * len(Method)
    (steps, kernel), (other_steps, other_kernel) = runs
    assert steps == other_steps  # results, instruction counts, durations and outputs
    assert (kernel.reports, kernel.logs) == (other_kernel.reports, other_kernel.logs)
    assert all(result.fault is None for _, result, _ in steps)
    assert sum(result.instructions for _, result, _ in steps) > 500


def test_gain_multiplies_saturates_and_reports(
    node: Node, example_builds: dict[str, ModuleBuild]
) -> None:
    gain = node.instance(node.load(example_builds["gain"].elf))
    assert gain.call(Method.INIT).ok
    result = gain.call(Method.ON)
    assert (result.status, node.kernel.logs) == (Status.ERR_INVALID, ["gain: k is not configured"])
    gain.put("k", round(2.5 * Q16))
    assert gain.call(Method.ON).ok
    outputs = []
    for x in (1.0, -3.25, 30000.0):
        node.kernel.time += 1e-3
        gain.put("x", round(x * Q16))
        assert gain.call(Method.CYCLE).ok
        outputs.append(gain.get("y"))
        assert gain.call(Method.EVALUATE).ok
    assert outputs == [round(2.5 * Q16), round(-8.125 * Q16), 2**31 - 1]  # the last saturates
    reports = node.kernel.reports
    functional = [value for kind, _, value in reports if kind is PerformanceKind.FUNCTIONAL]
    power = [value for kind, _, value in reports if kind is PerformanceKind.NON_FUNCTIONAL]
    assert functional[:2] == [0.0, 0.0] and functional[2] > 1000  # |y - k*x| once saturated
    # 0.5 mW idle, then 60 nJ per 1 ms period once two cycles were timed
    assert power == [0.5, pytest.approx(0.56), pytest.approx(0.56)]
    assert gain.call(Method.ERROR).ok
    assert gain.get("y") == 0  # error forces the output to its safe value
    assert node.kernel.logs[-1] == "gain: error, output forced to 0"


def test_the_estimator_never_disturbs_the_executor(
    node: Node, example_builds: dict[str, ModuleBuild]
) -> None:
    module = node.load(example_builds["moving_average"].elf)
    executor = node.instance(module)
    estimator = node.instance(module, Role.ESTIMATOR)
    assert executor.area != estimator.area
    assert executor.window == estimator.window  # the same place in the task window, in turn
    for instance in (executor, estimator):
        assert instance.call(Method.INIT).ok
    assert executor.call(Method.ON).ok
    for x in (1, 2, 3):
        executor.put("x", x * Q16)
        assert executor.call(Method.CYCLE).ok
    area = node.cpu.read(executor.area, module.layout.size)
    reports = len(node.kernel.reports)
    for _ in range(20):
        estimator.put("x", 50 * Q16)
        assert estimator.call(Method.ESTIMATE).ok
    assert estimator.get("y") == 50 * Q16
    assert node.cpu.read(executor.area, module.layout.size) == area
    assert [kind for kind, _, _ in node.kernel.reports[reports:]] == [
        PerformanceKind.FUNCTIONAL
    ] * 20  # an estimator reports no non-functional value
    executor.put("x", 4 * Q16)
    assert executor.call(Method.CYCLE).ok
    # the window was primed with 1 and holds 1, 1, 1, 1, 1, 2, 3, 4: the estimator left no trace
    assert executor.get("y") == round(14 / 8 * Q16)


def test_frame_and_vector_ports(node: Node, probe: ModuleBuild) -> None:
    module = node.load(probe.elf)
    assert [(p.name, p.direction, p.kind, p.dtype, p.shape) for p in module.ports] == [
        ("mode", Direction.CONST, PortKind.SCALAR, "<i4", ()),
        ("image", Direction.IN, PortKind.FRAME, "u1", (3, 5)),
        ("sums", Direction.OUT, PortKind.VECTOR, "<i2", (5,)),
        ("calls", Direction.OUT, PortKind.SCALAR, "<i4", ()),
    ]
    assert module.layout == AreaLayout(state=40, ports=(48, 56, 72, 88), size=96)
    probe_instance = node.instance(module)
    image = np.arange(15, dtype=np.uint8).reshape(3, 5) * 17
    probe_instance.put("image", image)
    assert probe_instance.call(Method.CYCLE).ok
    assert probe_instance.get("sums").tolist() == image.astype(int).sum(axis=0).tolist()
    assert probe_instance.call(Method.CYCLE).ok
    assert probe_instance.get("calls") == 2
    assert np.array_equal(probe_instance.get("image"), image)


def test_absent_methods_return_at_once(node: Node, probe: ModuleBuild) -> None:
    module = node.load(probe.elf)
    assert [method for method in Method if module.implements(method)] == [
        Method.INIT,
        Method.CYCLE,
    ]
    assert node.instance(module).call(Method.ON) == CallResult()


PREFIX = "module 'probe' at 0x08000000 (executor), cycle: "


@pytest.mark.parametrize(
    ("mode", "fault"),
    [
        (
            1,
            "PORT_READ of port 0 ('mode') into its destination: expected 4 bytes at 0x20000000 "
            "inside the task window or the stack, got a buffer in SRAM (ecall at 0x",
        ),
        (
            2,
            "PORT_WRITE: expected an OUT or RESOURCE port, got port 0 ('mode') of direction "
            "CONST (ecall at 0x",
        ),
        (3, "PORT_READ: expected a port index below 4, got 9 (ecall at 0x"),
        (
            4,
            "PORT_READ: expected the context 0x3000FFA0 of module 'probe' at 0x08000000 "
            "(executor), got 0x3000FFA4",
        ),
        (5, "memory fault: 4-byte write at 0x08000000 (flash, guest r-x) by the instruction"),
        (6, "memory fault: 4-byte write at 0x20000000 (SRAM, guest r--) by the instruction"),
        (7, "memory fault: 1-byte write at 0x30010000 (unmapped memory) by the instruction"),
        (8, "LOG: expected at most 256 bytes of text, got 1000 (ecall at 0x"),
        (9, "watchdog: instruction budget of 5000 exhausted at 0x"),
        (10, "REGISTER: not available to module 'probe' at 0x08000000 (executor) (ecall at 0x"),
        (11, "PERF_REPORT: expected kind 0 (functional) or 1 (non-functional), got 7 (ecall"),
        (
            12,
            "PORT_WRITE of port 3 ('calls') from its source: expected 4 bytes at 0x40000000 "
            "inside guest-readable memory, got a buffer in unmapped memory (ecall at 0x",
        ),
    ],
)
def test_misuse_faults_the_call_and_nothing_else(
    node: Node, probe: ModuleBuild, mode: int, fault: str
) -> None:
    module = node.load(probe.elf, budget=5000)
    executor = node.instance(module)
    bystander = node.instance(module, Role.ESTIMATOR)
    bystander.put("image", np.full((3, 5), 7, dtype=np.uint8))
    assert bystander.call(Method.CYCLE).ok
    bystander_area = node.cpu.read(bystander.area, module.layout.size)
    flash = node.cpu.read(FLASH_BASE, 16)

    executor.put("mode", mode)
    result = executor.call(Method.CYCLE)
    assert result.fault is not None
    assert result.fault.startswith(PREFIX + fault)
    assert not result.ok
    if mode == 9:
        assert result.instructions == 5000
    executor.put("mode", 0)
    assert executor.call(Method.CYCLE).ok
    assert executor.get("calls") == 2  # the faulting call's own writes stayed, as in memory
    assert node.cpu.read(bystander.area, module.layout.size) == bystander_area
    assert node.cpu.read(FLASH_BASE, 16) == flash


def test_registration_checks_the_descriptor(
    node: Node, example_builds: dict[str, ModuleBuild]
) -> None:
    image = image_from_elf(example_builds["gain"].elf)
    descriptor_offset = image.data.find(abi.MAGIC.to_bytes(4, "little"))
    assert descriptor_offset > 0

    def refusal(patch: dict[int, bytes], **options: object) -> str:
        data = bytearray(image.relocate(FLASH_BASE))
        for offset, value in patch.items():
            data[descriptor_offset + offset : descriptor_offset + offset + len(value)] = value
        init = node.install(image, FLASH_BASE, bytes(data))
        with pytest.raises(RegistrationError) as caught:
            register_module(
                node.cpu,
                node.sram,
                FLASH_BASE,
                image.size,
                init,
                node.kernel.services(),
                **options,
            )
        return str(caught.value)

    where = "module image at 0x08000000, init subroutine at 0x08000000: REGISTER refused"
    assert refusal({4: (2).to_bytes(2, "little")}) == (
        f"{where} (ERR_ABI): expected ABI version 1, got 2"
    )
    cycle_slot = abi.METHODS_OFFSET + 4 * abi.METHODS.index("cycle")
    assert refusal({cycle_slot: (FLASH_BASE + 0x10000).to_bytes(4, "little")}) == (
        f"{where} (ERR_INVALID): module 'gain': expected method cycle at a 4-byte aligned "
        f"address inside the module image at 0x08000000..0x{FLASH_BASE + image.size - 1:08X}, "
        "got 0x08010000"
    )
    assert refusal({8: b"x\0"}, taken={"x"}) == (
        f"{where} (ERR_EXISTS): a module 'x' is already loaded"
    )
    assert "expected distinct, non-empty port names, got ['x', 'x', 'k']" in refusal(
        {abi.METHODS_OFFSET - abi.MAX_PORTS * abi.PORT_SIZE + abi.PORT_SIZE: b"x\0"}
    )
    descriptor = node.register(image, FLASH_BASE)  # unpatched, it registers
    assert descriptor.name == "gain"


def test_registrar_statuses(node: Node, example_builds: dict[str, ModuleBuild]) -> None:
    image = image_from_elf(example_builds["gain"].elf)
    node.install(image, FLASH_BASE)
    address = FLASH_BASE + image.data.find(abi.MAGIC.to_bytes(4, "little"))
    registrar = Registrar(node.cpu, node.sram, FLASH_BASE, image.size, node.kernel.services())
    assert registrar.register(address + 4) == Status.ERR_INVALID  # straddles the image's end
    assert registrar.refusal is not None
    assert f"got it at 0x{address + 4:08X}" in registrar.refusal
    assert registrar.register(address) == Status.OK
    assert registrar.descriptor is not None and registrar.descriptor.name == "gain"
    assert registrar.register(address) == Status.ERR_EXISTS


def test_registration_needs_room_for_the_instance(tmp_path: Path) -> None:
    big = image_from_elf(build_probe(tmp_path, 64, 64).elf)
    with Cpu(MemoryMap(window_size=4096)) as cpu:
        node = Node(cpu)
        with pytest.raises(
            RegistrationError,
            match=r"\(ERR_NO_MEMORY\): module 'probe': needs a "
            r"4288-byte area, but the task window holds 4096 bytes",
        ):
            node.register(big, FLASH_BASE)


def test_init_subroutines_that_do_not_register(node: Node, probe: ModuleBuild) -> None:
    image = image_from_elf(probe.elf)
    module = node.load(probe.elf)
    silent = module.entry(Method.INIT)  # returns without REGISTER
    with pytest.raises(RegistrationError, match="returned without calling REGISTER"):
        register_module(node.cpu, node.sram, FLASH_BASE, image.size, silent, node.kernel.services())
    with pytest.raises(RegistrationError, match="memory fault: instruction fetch at 0x30000000"):
        register_module(
            node.cpu, node.sram, FLASH_BASE, image.size, WINDOW_BASE, node.kernel.services()
        )


def test_ports_by_name_and_released_instances(
    node: Node, example_builds: dict[str, ModuleBuild]
) -> None:
    module = node.load(example_builds["gain"].elf)
    gain = node.instance(module)
    free = node.sram.free_bytes
    assert free == node.sram.size - module.layout.size
    with pytest.raises(KeyError, match=r"expected one of the ports \['x', 'y', 'k'\], got 'z'"):
        gain.put("z", 1)
    with pytest.raises(ValueError, match=r"module 'gain' at 0x08000000 \(executor\), port 'x'"):
        gain.put("x", [1, 2])
    gain.release()
    gain.release()
    assert node.sram.free_bytes == node.sram.size
    with pytest.raises(RuntimeError, match="the instance was released"):
        gain.call(Method.CYCLE)


def test_instances_fill_sram_until_a_clear_error(example_builds: dict[str, ModuleBuild]) -> None:
    with Cpu(MemoryMap(sram_size=4096)) as cpu:
        node = Node(cpu)
        module = node.load(example_builds["gain"].elf)
        instances = [node.instance(module) for _ in range(4096 // module.layout.size)]
        with pytest.raises(OutOfSramError) as caught:
            node.instance(module, Role.ESTIMATOR)
        assert str(caught.value) == (
            f"out of SRAM: module 'gain' at 0x08000000 (estimator) requested "
            f"{module.layout.size} bytes ({module.layout.size} aligned), but only "
            f"{4096 % module.layout.size} of 4096 bytes are free and the largest free block is "
            f"{4096 % module.layout.size} bytes"
        )
        assert instances[0].area == SRAM_BASE
        assert node.cpu.read(instances[1].area, CONTEXT_SIZE)[:4] == (
            instances[1].window + module.layout.state
        ).to_bytes(4, "little")


def test_sram_allocator_is_first_fit_and_coalesces() -> None:
    sram = SramAllocator(SRAM_BASE, 256)
    a = sram.allocate(10, "a")  # rounded to 16
    b = sram.allocate(8, "b")
    c = sram.allocate(32, "c")
    assert (a, b, c) == (SRAM_BASE, SRAM_BASE + 16, SRAM_BASE + 24)
    assert (sram.used_bytes, sram.free_bytes, sram.largest_free) == (56, 200, 200)
    sram.free(a)
    assert sram.allocate(16, "d") == a  # first fit: the hole at the start
    sram.free(a)
    sram.free(b)
    assert sram.allocate(24, "e") == a  # the two neighbouring holes were merged
    assert [allocation.owner for allocation in sram.allocations] == ["e", "c"]
    with pytest.raises(OutOfSramError, match="f requested 201 bytes"):
        sram.allocate(201, "f")
    with pytest.raises(ValueError, match="expected the address of an allocated SRAM block"):
        sram.free(SRAM_BASE + 8)
    with pytest.raises(ValueError, match="expected a positive size, got 0"):
        sram.allocate(0, "g")
