"""An emulated node: CPU, flash, SRAM, the loader, the PBO/RT kernel and a power budget.

This is where `hexmigrate` and `pbort` meet (ARCHITECTURE.md): a module file arrives, the loader
writes it to flash block by block and fixes its pointers, its init subroutine registers it, and the
kernel runs it as a port-based object next to the node's native PBOs. A module is installed only
when every step succeeded; on any failure the node is as it was before (flash content, flash
space, SRAM, kernel), which `install` guarantees by undoing what was done.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType

from firmware_sim.cpu import Cpu
from firmware_sim.flash import BLOCK_SIZE, Flash, FlashTiming
from firmware_sim.flash_space import FlashSpace
from firmware_sim.guest import DEFAULT_BUDGET, GuestModule, register_module
from firmware_sim.loader import InstalledImage, LoadSession
from firmware_sim.memory_map import (
    DEFAULT_FLASH_SIZE,
    DEFAULT_SRAM_SIZE,
    DEFAULT_WINDOW_SIZE,
    FLASH_BASE,
    SRAM_BASE,
    MemoryMap,
)
from firmware_sim.power import PowerModel
from firmware_sim.sram import SramAllocator
from hexmigrate.image import ModuleImage
from pbort.clock import Clock
from pbort.code import ModuleCode, PerformanceKind, Services
from pbort.kernel import Kernel
from pbort.lifecycle import State

POWER_INDEX = 0  # the non-functional value an evaluator reports its draw (mW) under


@dataclass(frozen=True)
class NodeConfig:
    """The hardware of a node. Sizes in bytes, frequency in Hz, energy in J, draw in mW."""

    flash_size: int = DEFAULT_FLASH_SIZE
    sram_size: int = DEFAULT_SRAM_SIZE
    window_size: int = DEFAULT_WINDOW_SIZE
    cpu_frequency: float = 100e6
    budget: int = DEFAULT_BUDGET
    flash_timing: FlashTiming = field(default_factory=FlashTiming)
    energy: float = 3600.0
    base_draw: float = 50.0


@dataclass(frozen=True)
class InstalledModule:
    """A guest module on this node: where its image is and the code the kernel runs."""

    name: str
    image: InstalledImage
    code: GuestModule

    @property
    def load_address(self) -> int:
        """Where the image starts in flash."""
        return self.image.load_base

    @property
    def flash_blocks(self) -> list[int]:
        """Start addresses of the flash blocks the module occupies."""
        first = self.image.load_base
        return [first + BLOCK_SIZE * index for index in range(self.image.extent.count)]


class SramBlockBuffer:
    """The loader's block buffer, allocated in the node's SRAM for the duration of one load."""

    def __init__(self, cpu: Cpu, sram: SramAllocator, owner: str) -> None:
        self._cpu = cpu
        self._sram = sram
        self.address: int | None = sram.allocate(BLOCK_SIZE, f"loader buffer ({owner})")

    def store(self, offset: int, data: bytes) -> None:
        """Put `data` at `offset` of the block."""
        assert self.address is not None
        self._cpu.write(self.address + offset, data)

    def contents(self, length: int) -> bytes:
        """The first `length` bytes of the block."""
        assert self.address is not None
        return self._cpu.read(self.address, length)

    def release(self) -> None:
        """Free the buffer; a second call does nothing."""
        if self.address is not None:
            self._sram.free(self.address)
            self.address = None


class Node:
    """One emulated node. A context manager; `close` may be called twice."""

    def __init__(
        self, name: str = "node", config: NodeConfig | None = None, clock: Clock | None = None
    ) -> None:
        self.name = name
        self.config = config or NodeConfig()
        self.memory = MemoryMap(
            self.config.flash_size, self.config.sram_size, self.config.window_size
        )
        self.cpu = Cpu(self.memory, self.config.cpu_frequency)
        self.flash = Flash(
            FLASH_BASE, self.config.flash_size, self.config.flash_timing, on_change=self.cpu.write
        )
        self.space = FlashSpace(self.flash.block_count)
        self.sram = SramAllocator(SRAM_BASE, self.config.sram_size)
        self.kernel = Kernel(clock)
        self.power = PowerModel(self.config.energy, self.config.base_draw)
        self.modules: dict[str, InstalledModule] = {}
        self.log: list[tuple[float, str]] = []
        self._closed = False

    def __enter__(self) -> Node:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Stop the kernel and release the CPU."""
        if self._closed:
            return
        self._closed = True
        self.kernel.close()
        self.cpu.close()

    # Loading modules.

    def begin_load(
        self, owner: str, size: int | None = None, address: int | None = None
    ) -> LoadSession:
        """Start receiving a module record by record (for a transfer); finish with `install`.

        The block being received waits in a 256-byte buffer in SRAM, as on the paper's nodes.
        """
        buffer = SramBlockBuffer(self.cpu, self.sram, owner)
        try:
            return LoadSession(
                self.flash, self.space, owner, size=size, address=address, buffer=buffer
            )
        except Exception:
            buffer.release()
            raise

    def install(self, session: LoadSession) -> InstalledModule:
        """Finish a load, call the module's init subroutine and register the module.

        On any failure everything the load did is undone and the error is raised again.
        """
        with session:
            image = session.finish()
        try:
            code = self._register(image)
        except Exception:
            self._erase(image)
            self.space.free(session.owner)
            raise
        self.space.rename(session.owner, f"module:{code.name}")
        module = InstalledModule(code.name, image, code)
        self.modules[code.name] = module
        self._note(
            f"installed {code.name!r} at 0x{image.load_base:08X} "
            f"({image.size} bytes, {len(image.relocations)} pointers fixed)"
        )
        return module

    def load(self, source: ModuleImage | str | Path, address: int | None = None) -> InstalledModule:
        """Load a whole module (an image or a module file) through the streaming path."""
        image = source if isinstance(source, ModuleImage) else ModuleImage.read(source)
        session = self.begin_load(f"loading:{image.name}", image.size, address)
        with session:
            for line in image.to_hex().splitlines():
                session.feed_line(line)
        return self.install(session)

    def _register(self, image: InstalledImage) -> GuestModule:
        services = Services(
            report=lambda kind, index, value: None, now=self.kernel.now, log=self._note
        )
        descriptor = register_module(
            self.cpu,
            self.sram,
            image.load_base,
            image.size,
            image.init_address,
            services,
            taken=set(self.kernel.names),
            budget=self.config.budget,
        )
        return GuestModule(
            self.cpu, self.sram, descriptor, image.load_base, budget=self.config.budget
        )

    def unload(self, name: str) -> None:
        """Stop and remove a module, then free (and erase) its flash and its SRAM."""
        module = self.modules[name]
        if name in self.kernel.names:
            self.stop(name)
            self.kernel.remove(name)
        self._erase(module.image)
        self.space.free(f"module:{name}")
        del self.modules[name]
        self._note(f"unloaded {name!r}")

    def _erase(self, image: InstalledImage) -> None:
        end = image.load_base + image.extent.count * BLOCK_SIZE
        for address in range(image.load_base, end, BLOCK_SIZE):
            self.flash.erase(address)

    # Running PBOs.

    def start(
        self,
        code: ModuleCode | str,
        frequency: float | None = None,
        *,
        name: str | None = None,
        priority: int = 0,
        triggers: Iterable[str] = (),
        constants: dict[str, object] | None = None,
    ) -> str:
        """Register a PBO (an installed module by name, or any ModuleCode), set its constants,
        init it and switch it on. Returns its name."""
        if isinstance(code, str):
            code = self.modules[code].code
        name = self.kernel.add(code, name, frequency, priority, triggers)
        for port, value in (constants or {}).items():
            self.kernel.configure(f"{name}.{port}", value)
        self.kernel.spawn(name)
        self.kernel.on(name)
        return name

    def stop(self, name: str) -> None:
        """Switch a PBO off (when on) and kill it, from whatever state allows it."""
        state = self.kernel.state(name)
        if state is State.ON:
            self.kernel.off(name)
        if self.kernel.state(name) in (State.OFF, State.ERROR):
            self.kernel.kill(name)
        self.power.stop(name)

    def run(self, until: float | None = None, cycles: int | None = None, step: float = 0.01) -> int:
        """Run the kernel to `until` seconds (absolute) or for `cycles` jobs, updating the power
        budget every `step` seconds of virtual time from the evaluators' latest draws."""
        jobs = 0
        while True:
            target = self.kernel.now + step
            if until is not None:
                target = min(target, until)
            left = None if cycles is None else cycles - jobs
            ran = self.kernel.run(until=target, cycles=left)
            jobs += ran
            self._account_power()
            if until is not None and self.kernel.now >= until:
                return jobs
            if cycles is not None and (jobs >= cycles or (not ran and not self._running())):
                return jobs

    def _running(self) -> bool:
        return any(self.kernel.state(name) is State.ON for name in self.kernel.names)

    def _account_power(self) -> None:
        self.power.advance(self.kernel.now)
        for name in self.kernel.names:
            if self.kernel.state(name) is not State.ON:
                self.power.stop(name)
                continue
            latest = self.kernel.performance(name).latest(
                PerformanceKind.NON_FUNCTIONAL, POWER_INDEX
            )
            if latest is not None:
                self.power.set_draw(name, latest.value)

    def _note(self, text: str) -> None:
        self.log.append((self.kernel.now, text))
