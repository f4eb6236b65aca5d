"""The GDB stub of one node CPU: it answers gdb's packets and halts the guest where gdb asks.

How it halts: breakpoints are Unicorn code hooks on their address; a single step, an interrupt
and a pending watchpoint use a code hook on every instruction, and watchpoints memory hooks on
their range. A hook that must halt serves gdb right there, inside the hook, on the node's only
thread: nothing else of the node runs meanwhile, so its virtual clock stands still. Unicorn
applies a hook only to code it translates after the hook was added, and must not drop
translations while it runs one; so when gdb resumes after changing hooks, the stub stops the
emulation before the halted instruction, and the CPU starts it again there once the hooks are
in place (`Cpu.call`), its instruction count corrected to the instructions that completed. A pc
gdb writes while halted (`set $pc`, `jump`, `return`) is where the CPU starts again instead:
an instruction of the running call's code, or the trampoline, where the call returns at once.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from unicorn import UcError

from firmware_sim.core.debug_port import DebugPort, Restart
from firmware_sim.errors import KernelAccessError
from firmware_sim.gdb.packets import Disconnected, PacketConnection
from firmware_sim.gdb.target import (
    REGISTER_NAMES,
    SIGINT,
    SIGTRAP,
    TARGET_XML,
    parse_word,
    word_hex,
)

MAX_MEMORY_READ = 0x1000
"""Bytes one 'm' packet may read: the reply must fit the packet size we announce."""
PC = len(REGISTER_NAMES) - 1
"""pc's number in gdb's register list."""
WATCH_KINDS = {"2": (True, False), "3": (False, True), "4": (True, True)}
"""Z2 write, Z3 read, Z4 access watchpoints: (on writes, on reads)."""


@dataclass
class _Watch:
    address: int
    length: int
    kind: str
    handle: int | None = None


@dataclass
class _Plan:
    """What the hooks must be when the guest runs on: changed while halted, applied on resume."""

    breakpoints: dict[int, int | None] = field(default_factory=dict)  # address -> hook handle
    watches: dict[tuple[int, int, str], _Watch] = field(default_factory=dict)
    stepping: bool = False  # halt at the next instruction
    interrupted: bool = False  # ... because gdb interrupted (a SIGINT stop)
    step_hook: int | None = None
    dirty: bool = False


class GdbStub:
    """Serves one gdb connection for a node's debug `port`; `say` prints a line for the user."""

    def __init__(
        self, port: DebugPort, connection: PacketConnection, say: Callable[[str], None]
    ) -> None:
        self.port = port
        self.connection = connection
        self.say = say
        self.attached = True
        self._plan = _Plan()
        self._resume_from: int | None = None  # the halted pc: its own hooks do not halt again
        self._resume_visit: int | None = None  # the instruction count of that visit
        self._restart: Restart | None = None  # where Cpu.call starts the guest again
        self._halted_at: int | None = None  # the halted guest's pc, while gdb is served
        self._moved_to: int | None = None  # a pc gdb wrote meanwhile
        self._watch_hit: tuple[str, int] | None = None
        self._stop_reply = f"S{SIGTRAP:02x}"  # why the target is halted, for '?'

    # What the CPU asks.

    def before_call(self) -> None:
        """Before a guest call: notice an interrupt, and put pending hooks in place (the
        emulation is not running, so translations may be dropped)."""
        self.poll()
        self._apply()

    def take_restart(self) -> Restart | None:
        """Where the guest stopped and must start again after the stub stopped the emulation
        (None: it was not the stub), the hooks put in place first."""
        restart, self._restart = self._restart, None
        if restart is not None:
            self._apply()
        return restart

    def returned(self) -> None:
        """A guest call returned to the trampoline: halt there, a0 holding what the method
        returned, when gdb steps or has a breakpoint there (`finish` puts one on the return
        address, and so does gdb's own single step of a `ret`). Going on from there, a step, or
        a continue with that breakpoint still in place (how gdb single-steps the trampoline's
        `j .`), halts at the first instruction of the next guest call."""
        plan = self._plan
        if not self.attached or not (plan.stepping or self.port.trampoline in plan.breakpoints):
            return
        resumed = self._serve(SIGINT if plan.interrupted else SIGTRAP, None)
        if resumed == "continue" and self.port.trampoline in self._plan.breakpoints:
            self._plan.stepping = self._plan.dirty = True

    def poll(self) -> None:
        """Between jobs and calls: an interrupt from gdb halts at the next instruction."""
        if not self.attached:
            return
        try:
            self.connection.poll()
        except Disconnected:
            self._detach("gdb disconnected")
            return
        if self.connection.interrupted:
            self.connection.interrupted = False
            self._plan.stepping = self._plan.interrupted = self._plan.dirty = True

    # Halting.

    def halt_outside(self) -> None:
        """Serve gdb, which has just connected, while no guest runs: gdb asks why the target
        stopped ('?') rather than being told."""
        self._serve(SIGTRAP, None, announce=False)

    def _on_instruction(self, address: int) -> None:
        if address == self._resume_from:
            # The halted instruction runs now: every hook of this one visit lets it. A later
            # visit comes through a new block, which the block counter has counted.
            visit = self.port.instructions
            if self._resume_visit is None or visit == self._resume_visit:
                self._resume_visit = visit
                return
        self._resume_from = self._resume_visit = None
        if self._watch_hit is not None:
            kind, where = self._watch_hit
            self._watch_hit = None
            self._serve(SIGTRAP, address, f"{kind}:{where:x};")
        elif self._plan.stepping or address in self._plan.breakpoints:
            self._serve(SIGINT if self._plan.interrupted else SIGTRAP, address)

    def _on_access(self, address: int, _size: int, write: bool) -> None:
        for watch in self._plan.watches.values():
            if watch.address <= address < watch.address + watch.length:
                on_write, on_read = WATCH_KINDS[watch.kind]
                if (write and on_write) or (not write and on_read):
                    kind = {"2": "watch", "3": "rwatch", "4": "awatch"}[watch.kind]
                    self._watch_hit = (kind, watch.address)  # reported after the access

    def _serve(self, signal: int, pc: int | None, reason: str = "", announce: bool = True) -> str:
        """Report the stop (the answer to gdb's continue or step) and answer packets until gdb
        resumes; inside a hook, then stop the emulation so that the CPU starts it again at `pc`
        with the hooks gdb asked for. How gdb resumed: 'continue', 'step' or 'detach'."""
        if not self.attached:
            return "detach"
        self._plan.stepping = self._plan.interrupted = False
        self._plan.dirty = True
        self._stop_reply = f"T{signal:02x}{reason}"
        if announce:
            self._send(self._stop_reply)
        self._halted_at, self._moved_to = pc, None
        try:
            resumed = self._answer_until_resumed()
            at = pc if self._moved_to is None else self._moved_to
        finally:
            self._halted_at = self._moved_to = None
        if pc is not None and self.port.running:
            # The instruction gdb resumes at runs without halting again, as after a stop; at a
            # pc gdb moved to, a breakpoint there halts at once (gdb steps over none it did not
            # stop at), while a step runs that instruction.
            moved_onto_breakpoint = at != pc and at in self._plan.breakpoints
            halts_there = resumed == "detach" or (resumed == "continue" and moved_onto_breakpoint)
            self._resume_from = None if halts_there else at
            self._resume_visit = None
            self._restart = Restart(pc, at)
            self.port.stop_guest()
        return resumed

    def _answer_until_resumed(self) -> str:
        """'continue', 'step' or 'detach'."""
        while self.attached:
            try:
                packet = self.connection.receive()
            except Disconnected:
                self._detach("gdb disconnected")
                return "detach"
            assert packet is not None  # no timeout: it waits
            outcome = self._answer(packet.decode("latin-1"))
            if outcome is not None:
                return outcome
        return "detach"

    # Packets.

    def _answer(self, packet: str) -> str | None:
        """Answer one packet; a resuming one returns how (the reply comes at the next stop)."""
        command, body = packet[:1], packet[1:]
        if command == "c":
            return "continue"
        if command == "s":
            self._plan.stepping, self._plan.dirty = True, True
            return "step"
        if command in ("D", "k"):
            if command == "D":
                self._send("OK")
            self._detach("gdb detached")
            return "detach"
        handler = {
            "?": lambda: self._stop_reply,
            "g": self._read_registers,
            "G": lambda: self._write_registers(body),
            "p": lambda: self._read_register(body),
            "P": lambda: self._write_register(body),
            "m": lambda: self._read_memory(body),
            "M": lambda: self._write_memory(body),
            "Z": lambda: self._insert(body),
            "z": lambda: self._remove(body),
            "H": lambda: "OK",
            "T": lambda: "OK",
            "q": lambda: self._query(packet),
            "v": lambda: self._v_packet(packet),
        }.get(command)
        try:
            reply = handler() if handler is not None else ""
        except (ValueError, IndexError, OverflowError, UcError):
            reply = "E01"  # a malformed packet, or one the emulator refuses: the node runs on
        self._send(reply)
        return None

    def _send(self, data: str) -> None:
        try:
            self.connection.send(data)
        except Disconnected:
            self._detach("gdb disconnected")

    def _query(self, packet: str) -> str:
        if packet.startswith("qSupported"):
            return "PacketSize=4000;qXfer:features:read+;swbreak+;hwbreak+"
        if packet.startswith("qXfer:features:read:target.xml:"):
            offset, length = (int(x, 16) for x in packet.rsplit(":", 1)[1].split(","))
            chunk = TARGET_XML[offset : offset + length]
            return ("m" if offset + length < len(TARGET_XML) else "l") + chunk
        answers = {"qAttached": "1", "qC": "QC1", "qfThreadInfo": "m1", "qsThreadInfo": "l"}
        return answers.get(packet.split(":")[0], "")

    def _v_packet(self, packet: str) -> str:
        if packet.startswith("vMustReplyEmpty") or packet.startswith("vCont?"):
            return ""
        if packet.startswith("vKill"):
            self._detach("gdb killed the session")
            return "OK"
        return ""

    def _registers(self) -> list[int]:
        """x0..x31 and pc as gdb sees them: pc where gdb moved it, if it did."""
        values = self.port.registers()
        if self._moved_to is not None:
            values[PC] = self._moved_to
        return values

    def _read_registers(self) -> str:
        return "".join(word_hex(value) for value in self._registers())

    def _write_registers(self, body: str) -> str:
        words = [parse_word(body[8 * i : 8 * i + 8]) for i in range(len(body) // 8)]
        if len(words) > PC and words[PC] != self._registers()[PC] and not self._move(words[PC]):
            return "E01"
        for index, value in enumerate(words[1:PC], start=1):  # x0 is always 0
            self.port.write_register(index, value)
        return "OK"

    def _read_register(self, body: str) -> str:
        index = int(body, 16)
        if not 0 <= index < len(REGISTER_NAMES):
            return "E01"
        return word_hex(self._registers()[index])

    def _write_register(self, body: str) -> str:
        number, _, value = body.partition("=")
        index, word = int(number, 16), parse_word(value)
        if index == PC:
            return "OK" if self._move(word) else "E01"
        if not 0 <= index < len(REGISTER_NAMES):  # "-1" too: it would name x30 from the end
            return "E01"
        if index:  # x0 is always 0
            self.port.write_register(index, word)
        return "OK"

    def _move(self, pc: int) -> bool:
        """Move the halted guest's pc to `pc`, if a halted call may go on there."""
        if self._halted_at is None or not self.port.may_run_at(pc):
            return False
        self._moved_to = None if pc == self._halted_at else pc
        return True

    def _read_memory(self, body: str) -> str:
        address, length = (int(x, 16) for x in body.split(","))
        try:
            return self.port.read(address, min(length, MAX_MEMORY_READ)).hex()
        except KernelAccessError:
            return "E14"  # EFAULT: outside the memory map

    def _write_memory(self, body: str) -> str:
        """An ``M`` packet: within SRAM only (`DebugPort.writable`), else EACCES."""
        where, _, data = body.partition(":")
        address, _ = (int(x, 16) for x in where.split(","))
        written = bytes.fromhex(data)
        if not written:
            return "OK"
        if not self.port.writable(address, len(written)):
            return "E0d"  # EACCES: flash and the rest of the map are not a debugger's to write
        try:
            self.port.write(address, written)
        except KernelAccessError:
            return "E14"
        return "OK"

    def _insert(self, body: str) -> str:
        kind, address, length = _point(body)
        if kind in ("0", "1"):
            self._plan.breakpoints.setdefault(address, None)
        elif kind in WATCH_KINDS:
            self._plan.watches.setdefault((address, length, kind), _Watch(address, length, kind))
        else:
            return ""
        self._plan.dirty = True
        return "OK"

    def _remove(self, body: str) -> str:
        kind, address, length = _point(body)
        if kind in ("0", "1"):
            handle = self._plan.breakpoints.pop(address, None)
            if handle is not None:
                self.port.remove_hook(handle)
        elif kind in WATCH_KINDS:
            watch = self._plan.watches.pop((address, length, kind), None)
            if watch is not None and watch.handle is not None:
                self.port.remove_hook(watch.handle)
        else:
            return ""
        self._plan.dirty = True
        return "OK"

    # Hooks.

    def _apply(self) -> None:
        """Put the hooks the plan asks for in place and drop translations made without them."""
        plan = self._plan
        if not plan.dirty:
            return
        plan.dirty = False
        for address, handle in plan.breakpoints.items():
            if handle is None:
                plan.breakpoints[address] = self.port.hook_code(
                    self._on_instruction, address, address
                )
        for watch in plan.watches.values():
            if watch.handle is None:
                on_write, on_read = WATCH_KINDS[watch.kind]
                watch.handle = self.port.hook_access(
                    self._on_access, watch.address, watch.address + watch.length - 1,
                    write=on_write, read=on_read,
                )  # fmt: skip
        every_instruction = plan.stepping or bool(plan.watches)
        if every_instruction and plan.step_hook is None:
            plan.step_hook = self.port.hook_code(self._on_instruction, 1, 0)  # all
        elif not every_instruction and plan.step_hook is not None:
            self.port.remove_hook(plan.step_hook)
            plan.step_hook = None
        self.port.forget_translations()

    def _detach(self, why: str) -> None:
        """Remove every hook and let the guest run on as if gdb had never come."""
        if not self.attached:
            return
        self.attached = False
        plan = self._plan
        handles = [h for h in plan.breakpoints.values() if h is not None]
        handles += [w.handle for w in plan.watches.values() if w.handle is not None]
        handles += [plan.step_hook] if plan.step_hook is not None else []
        for handle in handles:
            self.port.remove_hook(handle)
        self._plan = _Plan(dirty=True)
        self.connection.close()
        self.say(f"gdb: {why}; the node runs on")


def _point(body: str) -> tuple[str, int, int]:
    """A Z/z packet's kind, address and length."""
    kind, address, length = body.split(",")[:3]
    return kind, int(address, 16), int(length.split(";")[0], 16)
