"""The node firmware's worst-case stack depth, measured statically, to size its stack.

The firmware (docs/firmware.md) has one stack, the last STACK_SIZE bytes of its RAM
(firmware/rv32/link.ld). Two things run on it:

- **main**: start.S's ``_start`` sets sp to ``__stack_top`` and calls ``main`` (no frame of its
  own), which boots and then polls forever;
- **trap**: start.S's vector, when module code traps (an ecall, a fault, the watchdog's timer).
  Module code runs in user mode on a stack of its own, but ``guest_enter`` leaves the kernel's
  sp in ``mscratch`` and the vector saves the module's registers (FRAME, 128 bytes) there, so a
  trap's depth lies on top of the kernel path that called the module (``module_call`` ->
  ``run_in_user_mode`` -> ``guest_enter``): `HARDWARE_EDGES` makes that one path of the graph.
  No trap can arrive while the firmware itself runs deeper: ``mscratch`` is 0 then, so a trap
  of the firmware's own parks the hart without touching the stack (``firmware_trap``), and the
  timer interrupt reaches the hart only in user mode (the firmware never sets ``mstatus.MIE``;
  trap.c). A trap cannot nest in a trap either: the vector zeroes ``mscratch`` before
  ``trap_from_module`` runs, and a service that reached module code again would show as a cycle
  through ``trap``.

Every firmware source is compiled with the build's compiler and flags, read from make
(FIRMWARE_CC, FIRMWARE_CFLAGS, FIRMWARE_SOURCES of firmware/firmware.mk), plus
``-fcallgraph-info=su``: GCC writes a VCG file per object with each function's frame and its
calls (a call through a pointer goes to ``__indirect_call``). The calls through pointers are
resolved by `INDIRECT_TARGETS`, read from the code; an indirect call of a function the table
does not list, an unbounded dynamic frame or a cycle ends the run with an error.

Each object is also disassembled: the functions GCC describes must take exactly the frame it
reports (so ``-msave-restore``'s ``__riscv_save_N``, whose stores GCC counts in the frame, adds
nothing), and the functions it does not (start.S's and module_call.c's assembly, libgcc's
64-bit shifts and divisions) take the frame their own instructions make. A function whose
instructions move sp other than by a constant must be one of `STACK_SWITCHES`, which say why
that is safe. Weak defaults (``*_default.c``) give way to the strong definitions, as in the link;
``--gc-sections`` only drops code, so it cannot deepen a path.

The deepest path is then set against the stack the firmware links (``__stack_top -
__stack_low`` of build/firmware/node.elf, which make brings up to date): a path deeper than the
stack ends the run with an error (tests/firmware/test_stack_depth.py runs it), since a stack
overflow writes over RAM without a word. ``--capacities-32k`` measures the build with the
capacities of a 32 KiB-SRAM MCU (firmware/capacities/capacities_32k.h, build/firmware/32k/
node.elf): its tables are smaller, but what GCC inlines may change with them.

    python benchmarks/firmware_stack.py [--keep DIR] [--capacities-32k]
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from firmware_sim.errors import QemuError
from firmware_sim.qemu.firmware_build import firmware_elf, linked_stack

ROOT = Path(__file__).resolve().parent.parent
INDIRECT = "__indirect_call"
SEND_BYTES = "firmware/main/main.c:send_bytes"
"""main.c's UART writer: receiver_init(send_bytes) and watch_push(send_bytes) are the only
writers ever given, and every frame writer's, binary_send_line's and binary_send_block_ack's
`send` is passed down from those two."""
INDIRECT_TARGETS: dict[str, tuple[str, ...]] = {
    # kernel/module_call.c's run: the board's runner, set once by trap_init (runtime_init, before
    # node_boot runs any init subroutine); the direct call of module code when no runner is set
    # never happens on this firmware.
    "module_call": ("firmware/rv32/trap.c:run_in_user_mode",),
    # check_names (inlined): registrar.c's accept passes its static `taken`, the only caller.
    "descriptor_accept": ("firmware/kernel/registrar.c:taken",),
    # `report`: main.c's say, passed by node_boot(say) to directory_load, report_slot and
    # node.c's say (a constant argument of its one caller made GCC's constprop copy).
    "directory_load": ("firmware/main/main.c:say",),
    "firmware/loader/flash_directory.c:report_slot": ("firmware/main/main.c:say",),
    "firmware/loader/node.c:say.constprop.0": ("firmware/main/main.c:say",),
    # struct frame_writer's send, set by frame_writer_start from binary_messages.c.
    "firmware/protocol/binary_frame.c:send_run": (SEND_BYTES,),
    "frame_writer_start": (SEND_BYTES,),
    "frame_writer_end": (SEND_BYTES,),
    # receiver.send, set by receiver_init(send_bytes).
    "firmware/protocol/receiver.c:send_line": (SEND_BYTES,),
    # the session verbs' answers (receiver.c's dispatch).
    "firmware/protocol/receiver.c:handle_session": (
        "session_challenge",
        "session_authenticate",
        "session_end",
    ),
    # watch_push(send_bytes)'s send, and the two writers watch_push gives push.
    "firmware/control/watch.c:push": (
        SEND_BYTES,
        "firmware/control/watch.c:report_values",
        "control_state_line",
    ),
    # kernel.config.now_us: runtime.c's kernel_config gives board_time_us.
    "kernel_init": ("board_time_us",),
    "kernel_now_us": ("board_time_us",),
    "kernel_reset": ("board_time_us",),
    # kernel.config.note and .wait_until_us: 0 in runtime.c's kernel_config, and both calls are
    # behind a check for 0: never made.
    "kernel_note": (),
    "kernel_run": (),
    # the log visitors: kernel_log's from control_text.c, and pbo.c's own.
    "module_log_since": (
        "firmware/control/control_text.c:take_line",
        "firmware/kernel/pbo.c:add_said",
    ),
}
"""For each function that calls through a pointer, every function the pointer can hold."""
HARDWARE_EDGES = {"guest_enter": ("trap",)}
"""Calls no instruction makes: module code entered by guest_enter's mret traps into start.S's
vector, whose frame goes on the kernel sp guest_enter left in mscratch."""
SCOPED_CALLS = {
    ("services_dispatch", "registrar_register"): "registrar_run",
}
"""Calls made only below a given function: services.c answers REGISTER only in an init
subroutine's scope (scope.module 0), which registrar_run alone enters before its module_call;
instance_call's scope always names the module, so a method's ecall never reaches the registrar."""
STACK_SWITCHES = {
    "guest_enter": "sp becomes the module stack's top; the kernel's stays in mscratch (start.S)",
    "trap": "takes the kernel's sp from mscratch, and the module's sp back from its frame",
    "module_call_jump": "sp back to the one module_call_save kept: a frame still on the stack",
}
"""Functions that set sp other than by a constant, and why their own frame is what their
constant adjustments take."""
STORES_AND_BRANCHES = frozenset(
    ("sw", "sh", "sb", "c.sw", "c.swsp", "beqz", "bnez", "beq", "bne", "blt", "bge", "bltu", "bgeu")
)
"""Mnemonics whose first operand is read, not written: sp there is no change of sp."""
CALL_RELOCATIONS = ("R_RISCV_CALL", "R_RISCV_CALL_PLT", "R_RISCV_JAL")

NODE = re.compile(r'node: \{ title: "([^"]+)" label: "([^"]*)"( shape : ellipse)?')
EDGE = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')
FRAME = re.compile(r"\\n(\d+) bytes \(([a-z,]+)\)$")
SYMBOL = re.compile(r"^[0-9a-f]+ <([^.>][^>]*)>:$")
INSTRUCTION = re.compile(r"^\s+[0-9a-f]+:\s+(\S+)\s*([^#]*)")
RELOCATION = re.compile(r"^\s+[0-9a-f]+: (R_RISCV_\w+)\s+(\S+)")
DECREMENT = re.compile(r"^sp,sp,-(\d+)$")
SAVE = re.compile(r"^__riscv_save_(\d+)$")


class StackError(Exception):
    """What keeps the depth from being measured."""


@dataclass
class Function:
    """One function of the graph: its frame in bytes, GCC's word for it ("static", "dynamic,
    bounded"; "disassembly" for a function GCC did not compile), what it calls."""

    frame: int
    kind: str
    callees: set[str] = field(default_factory=set)


@dataclass(frozen=True)
class Code:
    """What one function's instructions do to the stack: bytes of constant sp decrements, the
    __riscv_save_N it calls (None: none), whether it sets sp otherwise, what it calls."""

    decrement: int
    save: int | None
    switches: bool
    calls: frozenset[str]

    @property
    def frame(self) -> int:
        return self.decrement + (0 if self.save is None else save_bytes(self.save))


def save_bytes(registers: int) -> int:
    """The bytes __riscv_save_N leaves sp lowered by (libgcc's riscv/save-restore.S, ilp32): ra
    and s0..s(N-1) in words, rounded up to the 16-byte stack alignment."""
    return -(-4 * (registers + 1) // 16) * 16


# The build.


def make_variable(name: str, *settings: str) -> str:
    """A variable of the firmware's build as make expands it (firmware/firmware.mk), with the
    `settings` (``NAME=VALUE``) given to make."""
    printer = "stack-print-%: ; @echo $($*)"
    return subprocess.run(
        ["make", "-s", "--no-print-directory", "--eval", printer, *settings, f"stack-print-{name}"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()


def compile_sources(folder: Path, *settings: str) -> tuple[list[Path], Path]:
    """Every firmware source compiled into `folder` as the build compiles it (with the make
    `settings`: the capacities), with GCC's call graph beside each object; the objects and the
    libgcc the link adds (the recipe's ``-march=rv32im -mabi=ilp32 -print-libgcc-file-name``)."""
    compiler = make_variable("FIRMWARE_CC")
    flags = make_variable("FIRMWARE_CFLAGS", *settings).split()
    sources = make_variable("FIRMWARE_SOURCES").split()

    def build(source: str) -> Path:
        target = folder / (source.replace("/", "_").replace(".", "_") + ".o")
        command = [compiler, *flags, "-fcallgraph-info=su", "-c", source, "-o", str(target)]
        done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
        if done.returncode != 0:
            raise StackError(f"{source} does not compile:\n{done.stderr}")
        return target

    with ThreadPoolExecutor() as pool:
        objects = list(pool.map(build, sources))
    libgcc = subprocess.run(
        [compiler, "-march=rv32im", "-mabi=ilp32", "-print-libgcc-file-name"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    return objects, Path(libgcc)


# GCC's call graph.


def read_graph(objects: Iterable[Path]) -> tuple[dict[str, Function], dict[str, Path]]:
    """The functions GCC compiled, by its title ("file.c:name" for a static function), and the
    object defining each; a weak definition gives way to a strong one, as in the link."""
    functions: dict[str, Function] = {}
    defined_in: dict[str, Path] = {}
    for obj in objects:
        graph = obj.with_suffix(".ci")
        if not graph.exists():  # an assembly source: read_code covers it
            continue
        weak = weak_symbols(obj)
        here: dict[str, Function] = {}
        for line in graph.read_text().splitlines():
            if (node := NODE.match(line)) and not node.group(3):
                frame = FRAME.search(node.group(2))
                if frame is None or frame.group(2) == "dynamic":
                    raise StackError(f"{graph}: no bounded frame in {line}")
                here[node.group(1)] = Function(int(frame.group(1)), frame.group(2))
            elif edge := EDGE.match(line):
                here[edge.group(1)].callees.add(edge.group(2))
        for title, function in here.items():
            if title in functions and title in weak:
                continue
            if title in functions and title not in weak_symbols(defined_in[title]):
                raise StackError(f"{title} is defined in {defined_in[title]} and in {obj}")
            functions[title], defined_in[title] = function, obj
    return functions, defined_in


def weak_symbols(obj: Path) -> set[str]:
    """The functions `obj` defines weak (``nm``: W)."""
    out = subprocess.run(
        ["riscv64-unknown-elf-nm", str(obj)], capture_output=True, text=True, check=True
    ).stdout
    return {fields[2] for fields in map(str.split, out.splitlines()) if fields[1:2] == ["W"]}


def resolve_indirect(functions: dict[str, Function]) -> None:
    """Each call through a pointer replaced by the calls `INDIRECT_TARGETS` lists for it."""
    callers = {title for title, function in functions.items() if INDIRECT in function.callees}
    unlisted = callers - INDIRECT_TARGETS.keys()
    stale = INDIRECT_TARGETS.keys() - callers
    if unlisted or stale:
        raise StackError(
            f"indirect calls without a list of targets in INDIRECT_TARGETS: {sorted(unlisted)}; "
            f"listed but calling through no pointer (inlined or renamed?): {sorted(stale)}"
        )
    for title in callers:
        functions[title].callees.discard(INDIRECT)
        functions[title].callees.update(INDIRECT_TARGETS[title])


# The instructions.


def read_code(path: Path) -> dict[str, Code]:
    """Each function of an object or archive (``objdump -dr``), by its symbol: its stack
    adjustments, its __riscv_save_N, its calls (call relocations, save and restore aside)."""
    out = subprocess.run(
        ["riscv64-unknown-elf-objdump", "-dr", "--no-show-raw-insn", str(path)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    bodies: dict[str, list[str]] = {}
    body: list[str] = []
    for line in out.splitlines():
        if symbol := SYMBOL.match(line):
            body = bodies.setdefault(symbol.group(1), [])
        else:
            body.append(line)
    return {name: code_of(lines) for name, lines in bodies.items()}


def code_of(lines: list[str]) -> Code:
    """What the instructions `lines` of one function do to the stack (`read_code`)."""
    decrement, save, switches, calls = 0, None, False, set()
    for line in lines:
        if relocation := RELOCATION.match(line):
            kind, target = relocation.groups()
            if saved := SAVE.match(target):
                save = int(saved.group(1))
            elif kind in CALL_RELOCATIONS and not target.startswith((".", "__riscv_restore_")):
                calls.add(target)
        elif instruction := INSTRUCTION.match(line):
            mnemonic, operands = instruction.group(1), instruction.group(2).strip()
            if not operands.startswith("sp,") or mnemonic in STORES_AND_BRANCHES:
                continue
            if mnemonic in ("add", "addi", "c.addi", "c.addi16sp") and operands.startswith(
                "sp,sp,"
            ):
                if lowered := DECREMENT.match(operands):
                    decrement += int(lowered.group(1))
                continue
            switches = True
    return Code(decrement, save, switches, frozenset(calls))


def add_code(
    functions: dict[str, Function], defined_in: dict[str, Path], objects: list[Path], libgcc: Path
) -> tuple[int, int, int]:
    """Check that no function GCC compiled takes more than the frame GCC reports or calls what
    its graph does not show, and add the functions only the instructions describe (assembly,
    libgcc) that the graph calls. Returns the functions checked, those among them that call
    __riscv_save_N, and those that take less than GCC reports (a frame GCC planned, then
    dropped for a tail call: its figure is kept)."""
    code = {obj: read_code(obj) for obj in objects}
    saving = below = 0
    for title, function in functions.items():
        made = code[defined_in[title]].get(title.rpartition(":")[2])
        if made is None:
            raise StackError(f"{title}: no such symbol in {defined_in[title]}")
        if made.switches or made.frame > function.frame:
            raise StackError(
                f"{title}: GCC reports {function.frame} bytes, its instructions take "
                f"{made.decrement} + __riscv_save_{made.save} (switches sp: {made.switches})"
            )
        unseen = made.calls - {callee.rpartition(":")[2] for callee in function.callees}
        if unseen:
            raise StackError(f"{title} calls {sorted(unseen)}, which GCC's graph does not show")
        saving += made.save is not None
        below += made.frame < function.frame
    assembly = {name: made for found in code.values() for name, made in found.items()}
    assembly.update(read_code(libgcc))
    missing = called(functions) - functions.keys()
    while missing:
        name = missing.pop()
        made = assembly.get(name)
        if made is None:
            raise StackError(f"{name} is called but defined nowhere")
        if made.switches and name not in STACK_SWITCHES:
            raise StackError(f"{name} moves sp other than by a constant: see STACK_SWITCHES")
        callees = made.calls | set(HARDWARE_EDGES.get(name, ()))
        functions[name] = Function(made.frame, "disassembly", set(callees))
        missing |= callees - functions.keys()
    return len(defined_in), saving, below


def called(functions: dict[str, Function]) -> set[str]:
    """Every function some function of `functions` calls."""
    return {callee for function in functions.values() for callee in function.callees}


# The depth.


def deepest(
    functions: dict[str, Function], entry: str, scoped: dict[tuple[str, str], str]
) -> list[str]:
    """The path from `entry` whose frames add up to the most bytes, where a call of `scoped`
    counts only below the function it names; a cycle is an error."""
    memo: dict[tuple[str, frozenset[str]], tuple[int, list[str]]] = {}
    scopes = frozenset(scoped.values())

    def walk(title: str, path: tuple[str, ...], inside: frozenset[str]) -> tuple[int, list[str]]:
        if title in path:
            cycle = " -> ".join((*path[path.index(title) :], title))
            raise StackError(f"recursion, the depth has no bound: {cycle}")
        inside = inside | ({title} & scopes)
        if (title, inside) not in memo:
            below = [
                walk(callee, (*path, title), inside)
                for callee in functions[title].callees
                if (title, callee) not in scoped or scoped[title, callee] in inside
            ]
            bytes_below, rest = max(below, default=(0, []))
            memo[title, inside] = (functions[title].frame + bytes_below, [title, *rest])
        return memo[title, inside]

    return walk(entry, (), frozenset())[1]


def check_scoped(functions: dict[str, Function]) -> None:
    """Every call of `SCOPED_CALLS` is still one the graph has."""
    for caller, callee in SCOPED_CALLS:
        if callee not in functions.get(caller, Function(0, "")).callees:
            raise StackError(f"SCOPED_CALLS: {caller} no longer calls {callee}")


def total(functions: dict[str, Function], path: list[str]) -> int:
    """The bytes of the frames of `path`."""
    return sum(functions[title].frame for title in path)


def print_path(functions: dict[str, Function], entry: str, path: list[str]) -> None:
    """`entry`'s deepest path, each frame with the depth below it."""
    print(f"{entry}: {total(functions, path):,} bytes at most, {len(path)} frames deep")
    depth = 0
    for title in path:
        depth += functions[title].frame
        frame = functions[title]
        print(f"  {frame.frame:>5} {depth:>6}  {title} ({frame.kind})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--keep", type=Path, help="a folder to keep the objects and GCC's .ci files in"
    )
    parser.add_argument(
        "--capacities-32k",
        action="store_true",
        help="measure the build with the capacities of a 32 KiB-SRAM MCU (make firmware-32k)",
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="firmware-stack-") as folder:
        try:
            stack = linked_stack(firmware_elf(capacities_32k=args.capacities_32k))
            settings = (
                [f"FIRMWARE_CAPACITIES={make_variable('FIRMWARE_CAPACITIES_32K')}"]
                if args.capacities_32k
                else []
            )
            objects, libgcc = compile_sources(Path(folder), *settings)
            functions, defined_in = read_graph(objects)
            resolve_indirect(functions)
            checked = add_code(functions, defined_in, objects, libgcc)
            check_scoped(functions)
            # a trap alone may come from any module call, an init subroutine's too
            paths = {
                "main": deepest(functions, "main", SCOPED_CALLS),
                "trap": deepest(functions, "trap", {}),
            }
            anywhere = total(functions, deepest(functions, "main", {}))
        except (StackError, QemuError) as error:  # QemuError: the ELF would not build or read
            sys.exit(f"firmware_stack: {error}")
        finally:
            if args.keep:
                shutil.copytree(folder, args.keep, dirs_exist_ok=True)
    compiled, saving, below = checked
    print(
        f"{len(functions)} functions; none of the {compiled} GCC compiled takes more than the "
        f"frame GCC reports ({saving} call __riscv_save_N, {below} take less: GCC's figure kept)"
    )
    for entry, path in paths.items():
        print_path(functions, entry, path)
    print(f"main if REGISTER answered in a method's scope too: {anywhere:,} bytes")
    dynamic = sorted(title for title, function in functions.items() if "dynamic" in function.kind)
    print(f"dynamic frames: {', '.join(dynamic) if dynamic else 'none'}")
    deepest_bytes = max(total(functions, path) for path in paths.values())
    if deepest_bytes > stack:
        sys.exit(
            f"firmware_stack: expected the deepest path to fit the linked stack of {stack:,} "
            f"bytes (STACK_SIZE in firmware/rv32/link.ld), got {deepest_bytes:,}"
        )
    print(f"linked stack {stack:,} bytes: {stack - deepest_bytes:,} to spare")


if __name__ == "__main__":
    main()
