"""An emulated node: CPU, flash, SRAM, the loader, the PBO/RT kernel and a power budget.

This is where `hexmigrate` and `pbort` meet (docs/node.md): a module file arrives, the loader
writes it to flash block by block and fixes its pointers, its init subroutine registers it, and the
kernel runs it as a port-based object next to the node's native PBOs. A module is installed only
when every step succeeded; on any failure the node is as it was before (flash content, flash
space, SRAM, kernel), which `commit` guarantees by undoing what was done.

The flash directory (`firmware_sim/core/flash_directory.py`) is the commit point: a module belongs
to the node once the directory lists it, and a node whose flash is a file (`NodeConfig.flash_file`)
boots with exactly the modules the directory lists, whatever moment a power cut struck.
"""

from __future__ import annotations

import zlib
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType

from firmware_sim.core.cpu import Cpu
from firmware_sim.core.flash import BLOCK_SIZE, Flash, FlashTiming
from firmware_sim.core.flash_directory import OWNER as DIRECTORY_OWNER
from firmware_sim.core.flash_directory import (
    SLOT_COUNT,
    DirectoryEntry,
    KeptVersion,
    ModuleDirectory,
)
from firmware_sim.core.flash_space import Extent, FlashSpace
from firmware_sim.core.fpga_port import ReconfigurationPort
from firmware_sim.core.guest import DEFAULT_BUDGET, GuestModule, register_module
from firmware_sim.core.loader import InstalledImage, LoadSession
from firmware_sim.core.memory_map import (
    DEFAULT_FLASH_SIZE,
    DEFAULT_SRAM_SIZE,
    DEFAULT_WINDOW_SIZE,
    FLASH_BASE,
    SRAM_BASE,
    MemoryMap,
)
from firmware_sim.core.power import PowerModel
from firmware_sim.core.source_lines import source_lines
from firmware_sim.core.sram import SramAllocator
from firmware_sim.core.trust import TrustPolicy, linked_image, version_of, version_word
from firmware_sim.errors import (
    BootError,
    FlashError,
    FlashFullError,
    PowerReportError,
    RegistrationError,
    TrustError,
)
from hexmigrate.image import ModuleImage
from pbort.clock import Clock
from pbort.code import ModuleCode, PerformanceKind, Services
from pbort.errors import MethodFailedError
from pbort.kernel import Kernel
from pbort.lifecycle import REMOVABLE, State

RATE_MIN, RATE_MAX = 0.01, 100_000.0
"""A PBO's frequency in Hz: once every 100 s to 100 kHz (a 100 MHz node spends its 1000
instructions a period on the kernel's copies already)."""
LOG_LINES = 1000
"""Notes a node keeps: a node that runs for weeks installing modules must not grow with them."""
POWER_INDEX = 0  # the non-functional value an evaluator reports its draw (mW) under


@dataclass(frozen=True)
class NodeConfig:
    """The hardware of a node. Sizes in bytes, frequency in Hz, energy in J, draw in mW.

    `flash_file` makes the flash non-volatile: a raw image of `flash_size` bytes (created when
    missing) and its ".blocks" sidecar of wear counters; None keeps the flash in memory only.
    `elves` are module ELFs (built with -g) the node may find an installed module's source
    lines in: a fault then names the function, file and line (a module loaded from a file also
    finds the ELF beside it).
    """

    flash_size: int = DEFAULT_FLASH_SIZE
    sram_size: int = DEFAULT_SRAM_SIZE
    window_size: int = DEFAULT_WINDOW_SIZE
    cpu_frequency: float = 100e6
    budget: int = DEFAULT_BUDGET
    flash_timing: FlashTiming = field(default_factory=FlashTiming)
    energy: float = 3600.0
    base_draw: float = 50.0
    flash_file: Path | None = None
    trust: TrustPolicy = field(default_factory=TrustPolicy)
    elves: tuple[Path, ...] = ()


@dataclass(frozen=True)
class InstalledModule:
    """A guest module on this node: where its image is, the code the kernel runs, and its line
    in the flash directory.

    A module brought back by `Node.boot` has an image with no relocation addresses (they were
    applied when it was committed; the directory keeps only their count, `entry.relocations`)
    and a `flash_time` of 0 (nothing was written).
    """

    name: str
    image: InstalledImage
    code: GuestModule
    entry: DirectoryEntry

    @property
    def load_address(self) -> int:
        """Where the image starts in flash."""
        return self.image.load_base

    @property
    def flash_blocks(self) -> list[int]:
        """Start addresses of the flash blocks the module occupies."""
        return self.image.flash_blocks


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
    """One emulated node. A context manager; `close` may be called twice.

    With a flash file that holds a directory, the node boots: the committed modules are
    registered again (not started) before the constructor returns.
    """

    def __init__(
        self,
        name: str = "node",
        config: NodeConfig | None = None,
        clock: Clock | None = None,
        fpga: ReconfigurationPort | None = None,
    ) -> None:
        self.name = name
        self.config = config or NodeConfig()
        self.fpga = fpga
        """The FPGA reconfiguration port, on a node with a fabric: partial bitstreams sent to
        the node configure it (`NodeTarget`), hardware E-PBOs stream through it
        (`firmware_sim.core.fabric_pbo`). A device of the board, like its flash."""
        self.memory = MemoryMap(
            self.config.flash_size, self.config.sram_size, self.config.window_size
        )
        self.cpu = Cpu(self.memory, self.config.cpu_frequency)
        try:
            self.flash = Flash(
                FLASH_BASE,
                self.config.flash_size,
                self.config.flash_timing,
                on_change=self.cpu.write,
                path=self.config.flash_file,
            )
        except BaseException:
            self.cpu.close()
            raise
        self.directory = ModuleDirectory(self.flash)
        self.space = FlashSpace(self.flash.block_count)
        self.space.place(DIRECTORY_OWNER, self.directory.first_block, SLOT_COUNT)
        self.sram = SramAllocator(SRAM_BASE, self.config.sram_size)
        self._elves: list[Path] = list(self.config.elves)  # where _find_source looks
        self.kernel = Kernel(clock)
        self.horizon = 0.0
        """The time the last `run` with an `until` was to go to: a lock-step node's quantum end,
        which its firmware stamps on what it sends to devices in other processes (they are at
        the quantum's end during the quantum, as devices in process are at the step's)."""
        self.power = PowerModel(self.config.energy, self.config.base_draw)
        self.modules: dict[str, InstalledModule] = {}
        self.kept_versions: dict[str, int] = {}
        """The highest signed version word of each name the flash holds no image of (a module
        removed, a partial bitstream applied): the directory's kept versions."""
        self.log: deque[tuple[float, str]] = deque(maxlen=LOG_LINES)
        """What the node noted (installs, boots, refused reports), the newest LOG_LINES."""
        self._refused_draws: set[str] = set()  # PBOs whose latest draw report was refused
        self._closed = False
        self.boot_problems: list[str] = []
        """What the boot found damaged and left out (a directory slot, a module), each as its
        note says it: a command shows them, as the C node says them on its UART."""
        try:
            self.boot()
        except BaseException:
            self.close()
            raise

    def status(self, since: float) -> dict[str, float | int]:
        """What a node says of itself beside its PBOs: its ``leftover`` power (0-100) and how
        it kept real time since time `since` (``slip``, the largest of its jobs, in ms rounded
        to 0.1 ms; ``missed``, the releases missed on slips since its clock started:
        `pbort.timekeeping`)."""
        keeping = self.kernel.timekeeping
        return {
            "leftover": self.power.leftover,
            "slip": round(keeping.worst_since(since) * 1e3, 1),
            "missed": keeping.missed,
        }

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
        """Stop the kernel and release the CPU and the flash file (which is already current)."""
        if self._closed:
            return
        self._closed = True
        self.kernel.close()
        self.cpu.close()
        self.flash.close()

    def boot(self) -> list[InstalledModule]:
        """Register again every module the flash directory lists whose image is intact.

        Called by the constructor. Each entry's blocks are taken, its image's CRC-32 checked,
        and its init subroutine run; an entry that fails any check is skipped and the node's log
        says why. The modules are not started: that is the application's job. Blocks no valid
        entry owns stay free, so the remains of a transfer cut short are erased on reuse.
        """
        scan = self.directory.scan()
        for problem in scan.problems:
            self._boot_problem(problem)
        if scan.newest is None:
            return []
        self.kept_versions = {kept.name: kept.version for kept in scan.newest.kept}
        booted = []
        for entry in scan.newest.entries:
            try:
                booted.append(self._restore(entry))
            except (BootError, FlashError, FlashFullError, RegistrationError) as error:
                self._boot_problem(f"boot: skipped module {entry.name!r}: {error}")
                if entry.version:  # the next directory write keeps it, as for a removed module
                    self.kept_versions[entry.name] = entry.version
        return booted

    def _restore(self, entry: DirectoryEntry) -> InstalledModule:
        """Take an entry's blocks, check its image and register it."""
        first = self.flash.block_of(entry.load_address)
        if (entry.load_address - self.flash.base) % BLOCK_SIZE or entry.size <= 0:
            raise BootError(
                f"expected a block-aligned load address and a size > 0, got "
                f"0x{entry.load_address:08X} and {entry.size} bytes"
            )
        owner = f"module:{entry.name}"
        extent = self.space.place(owner, first, -(-entry.size // BLOCK_SIZE))
        try:
            image = self._image_of(entry, extent)
            code = self._register(image, taken=set(self.kernel.names) | set(self.modules))
        except BaseException:
            self.space.free(owner)
            raise
        module = InstalledModule(code.name, image, code, entry)
        self.modules[code.name] = module
        self._note(f"booted {code.name!r} at 0x{image.load_base:08X} ({image.size} bytes)")
        return module

    def _image_of(self, entry: DirectoryEntry, extent: Extent) -> InstalledImage:
        """The installed image an entry describes, once its bytes in flash match its CRC-32."""
        crc = zlib.crc32(self.flash.read(entry.load_address, entry.size))
        if crc != entry.crc32:
            raise BootError(
                f"the image at 0x{entry.load_address:08X} ({entry.size} bytes) has CRC-32 "
                f"0x{crc:08X}, the directory expects 0x{entry.crc32:08X}"
            )
        delta = entry.load_address - entry.link_base
        return InstalledImage(
            link_base=entry.link_base,
            load_base=entry.load_address,
            size=entry.size,
            relocations=(),
            init=(entry.init_address - delta) % (1 << 32),
            crc32=entry.crc32,
            extent=extent,
            flash_time=0.0,
        )

    # Loading modules.

    def begin_load(
        self,
        owner: str,
        size: int | None = None,
        address: int | None = None,
        most: int | None = None,
    ) -> LoadSession:
        """Start receiving a module record by record (for a transfer); finish with `install`
        (or `session.finish()`, then `commit` or `discard`). Without a `size`, the largest free
        run of flash is reserved, at most `most` blocks of it.

        The block being received waits in a 256-byte buffer in SRAM, as on the paper's nodes.
        """
        buffer = SramBlockBuffer(self.cpu, self.sram, owner)
        try:
            return LoadSession(
                self.flash, self.space, owner, size=size, address=address, buffer=buffer, most=most
            )
        except Exception:
            buffer.release()
            raise

    def install(self, session: LoadSession) -> InstalledModule:
        """Finish a load and commit it; on any failure everything the load did is undone and
        the error is raised again."""
        with session:
            image = session.finish()
        return self.commit(session.owner, image)

    def commit(self, owner: str, image: InstalledImage) -> InstalledModule:
        """Make a received image (flash owner `owner`) one of the node's modules.

        Its init subroutine registers it; a module of the same name is replaced, so only the
        names of other PBOs are taken. Then the directory is written: the commit point (the
        module's version moves from the kept versions, if there, to its entry). Only
        after it is the module it replaces stopped, removed from the kernel, and its flash freed
        and erased, so a failure before it (the new module does not register, the directory is
        full) discards the new image and leaves the old module exactly as it was, running if it
        ran, and a power cut at any moment leaves one of the two listed in the directory.
        """
        try:
            version, signed = self._admit(owner, image)
            code = self._register(image, taken=set(self.kernel.names) - set(self.modules))
            if signed is not None and code.name != signed:
                raise TrustError(
                    f"it registers a PBO named {code.name!r} but was signed as {signed!r}: a "
                    "signature binds the name the module registers"
                )
            entry = self._entry(code.name, image, version)
            kept = [module.entry for name, module in self.modules.items() if name != code.name]
            versions = {name: v for name, v in self.kept_versions.items() if name != code.name}
            self.directory.write([*kept, entry, *_kept(versions)])
        except Exception:
            self.discard(owner, image)
            raise
        self.kept_versions = versions
        replaced = self.modules.pop(code.name, None)
        if replaced is not None:
            self._retire(replaced)
        self.space.rename(owner, f"module:{code.name}")
        module = InstalledModule(code.name, image, code, entry)
        self.modules[code.name] = module
        self._note(
            f"installed {code.name!r} at 0x{image.load_base:08X} "
            f"({image.size} bytes, {len(image.relocations)} pointers fixed)"
            + (f", replacing the one at 0x{replaced.load_address:08X}" if replaced else "")
        )
        return module

    def _admit(self, owner: str, image: InstalledImage) -> tuple[int, str | None]:
        """The signed version word for the directory and the name the image was signed under
        (0 and None when the node trusts no key), once the trust policy admits the image as it
        sits in flash (its CRC already checked), before its init runs; `TrustError` with the
        reason otherwise. The name is the one its versions are checked against: the PBO its
        init registers must bear it (a decoy descriptor must not lend its name)."""
        if not self.config.trust.enforced:
            return 0, None
        linked = linked_image(
            owner,
            self.flash.read(image.load_base, image.size),
            image.link_base,
            image.load_base,
            image.relocations,
            image.init,
            image.signature,
        )
        return self.admit(linked), linked.name

    def admit(self, image: ModuleImage, versions_of: str | None = None) -> int:
        """The signed version word of `image` (the bytes that were signed), once the trust
        policy admits it against the highest version the node keeps of its name (or of
        `versions_of`: a bitstream's slot, whatever name it was signed under): its installed
        module's, else its kept version. 0 when the node trusts no key; `TrustError` with the
        reason the sender is told otherwise."""
        name = image.name if versions_of is None else versions_of
        installed = self.modules.get(name)
        highest = installed.entry.version if installed else self.kept_versions.get(name, 0)
        version = self.config.trust.admit(
            image, version_of(highest) if highest else None, installed=installed is not None
        )
        return version_word(version) if version is not None else 0

    def keep_version(self, name: str, version: int) -> None:
        """Keep `version` (a word, as `admit` gives) as the highest of `name`, which has no
        image in flash (a partial bitstream the FPGA port takes): a directory write, so it
        survives a power cut at any block. Version 0 (a node that trusts no key) keeps nothing;
        a full directory raises `DirectoryError` before the flash is touched."""
        if not version:
            return
        versions = {**self.kept_versions, name: version}
        self.directory.write(
            [*(module.entry for module in self.modules.values()), *_kept(versions)]
        )
        self.kept_versions = versions

    def discard(self, owner: str, image: InstalledImage) -> None:
        """Erase and free a received image that is not to be committed."""
        self._erase(image)
        self.space.free(owner)

    def _entry(self, name: str, image: InstalledImage, version: int) -> DirectoryEntry:
        """The directory line of an image about to be committed, with its version word."""
        return DirectoryEntry(
            name=name,
            load_address=image.load_base,
            size=image.size,
            link_base=image.link_base,
            init_address=image.init_address,
            relocations=len(image.relocations),
            crc32=image.crc32,
            sequence=self.directory.scan().next_sequence,
            version=version,
        )

    def load(self, source: ModuleImage | str | Path, address: int | None = None) -> InstalledModule:
        """Load a whole module (an image or a module file) through the streaming path."""
        image = source if isinstance(source, ModuleImage) else ModuleImage.read(source)
        beside = None if isinstance(source, ModuleImage) else Path(source).with_suffix(".elf")
        if beside is not None and beside not in self._elves:
            self._elves.append(beside)
        session = self.begin_load(f"loading:{image.name}", image.size, address)
        with session:
            session.feed_image(image)
        return self.install(session)

    def _register(self, image: InstalledImage, taken: set[str]) -> GuestModule:
        services = Services(
            report=lambda kind, index, value: None, now=lambda: self.kernel.now, log=self._note
        )
        descriptor = register_module(
            self.cpu,
            self.sram,
            image.load_base,
            image.size,
            image.init_address,
            services,
            taken=taken,
            budget=self.config.budget,
        )
        module = GuestModule(
            self.cpu, self.sram, descriptor, image.load_base, image.size, budget=self.config.budget
        )
        module.link_base = image.link_base
        self._find_source(module)
        return module

    def _find_source(self, module: GuestModule) -> None:
        """Give a module the source lines of the first known ELF that is its installed build; an
        ELF of its name that is another build is named in the log, never used."""
        installed = self.cpu.read(module.load_address, len(module.image))
        for path in self._elves:
            if not path.is_file():
                continue
            try:
                lines = source_lines(path.resolve(), path.stat().st_mtime)
            except ValueError as error:
                self._note(f"no source lines from {error}")
                continue
            if lines.matches(installed, module.load_address):
                module.source = lines
                return
            if lines.image.name == module.name:
                self._note(
                    f"{path} is not the build of module {module.name!r} that is installed: "
                    "its faults are reported without source lines"
                )

    def unload(self, name: str) -> None:
        """Write the directory without the module, then stop and remove it and free (and erase)
        its flash and its SRAM. A power cut before the directory write completes leaves the
        module installed; one after it leaves it gone (its blocks are free, erased or not).

        A signed module's version stays, among the directory's kept versions, written by the
        same directory write: a node that trusts keys refuses an older one of that name after
        ``rm`` as before it. The write always fits, a kept version being smaller than an entry.
        """
        module = self.modules[name]
        versions = dict(self.kept_versions)
        if module.entry.version:
            versions[name] = module.entry.version
        entries = [m.entry for other, m in self.modules.items() if other != name]
        self.directory.write([*entries, *_kept(versions)])
        self.kept_versions = versions
        del self.modules[name]
        self._retire(module)
        self._note(f"unloaded {name!r}")

    def _retire(self, module: InstalledModule) -> None:
        """Take a module that left the directory off the node: its PBO out of the kernel,
        whatever its off and kill methods answer (its code is about to be erased), then its
        flash blocks freed and erased."""
        name = module.name
        if name in self.kernel.names:
            while self.kernel.state(name) not in REMOVABLE:
                try:
                    self.stop(name)
                except MethodFailedError as error:
                    self._note(f"stopping {name!r} on its way out: {error}")
            self.kernel.remove(name)
        self.space.free(f"module:{name}")
        self._erase(module.image)

    def _erase(self, image: InstalledImage) -> None:
        for address in image.flash_blocks:
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
        switch_on: bool = True,
    ) -> str:
        """Register a PBO (an installed module by name, or any ModuleCode), set its constants,
        init it and switch it on (unless not `switch_on`: then it waits OFF for a host's
        start). Returns its name."""
        if isinstance(code, str):
            code = self.modules[code].code
        name = self.kernel.add(code, name, frequency, priority, triggers)
        for port, value in (constants or {}).items():
            self.kernel.configure(f"{name}.{port}", value)
        self.kernel.spawn(name)
        if switch_on:
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

    def restart_clock(self) -> None:
        """The kernel's clock from 0 s again (no PBO may run), and the lock-step horizon with
        it: a new run of the task starts here."""
        self.power.advance(self.kernel.now)  # what was drawn until now stays drawn
        self.kernel.restart_clock()
        self.power.restart()
        self.horizon = 0.0

    def run(self, until: float | None = None, cycles: int | None = None, step: float = 0.01) -> int:
        """Run the kernel to `until` seconds (absolute) or for `cycles` jobs, updating the power
        budget every `step` seconds of virtual time from the evaluators' latest draws."""
        if until is not None:
            self.horizon = until
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
            if latest is None:
                continue
            try:
                self.power.set_draw(name, latest.value)
                self._refused_draws.discard(name)
            except PowerReportError as error:  # a module's bad report must not stop the node
                self.power.stop(name)
                if name not in self._refused_draws:
                    self._refused_draws.add(name)
                    self._note(f"power: {error}; its draw is not counted until it reports one")

    def _note(self, text: str) -> None:
        self.log.append((self.kernel.now, text))

    def _boot_problem(self, text: str) -> None:
        self.boot_problems.append(text)
        self._note(text)


def _kept(versions: dict[str, int]) -> list[KeptVersion]:
    """The directory's kept versions, from name -> version word."""
    return [KeptVersion(name, version) for name, version in versions.items()]
