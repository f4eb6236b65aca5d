"""`firmware-sim run --gdb`: gdb-multiarch breaks in a guest module's cycle, reads an argument
register and a port buffer, steps, watches a port and continues; an interrupt halts a running
guest; the node's virtual clock stands still while gdb holds it; gdb leaving lets it run on."""

from __future__ import annotations

import itertools
import json
import re
import shutil
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from pathlib import Path

import pytest

from commandline.children import Child
from firmware_sim.gdb.packets import PacketConnection
from hexmigrate.elf import image_from_elf
from module_sdk.build import EXAMPLES_DIR
from module_sdk.build import main as build_main

GDB = shutil.which("gdb-multiarch")
pytestmark = pytest.mark.skipif(GDB is None, reason="needs gdb-multiarch (make test installs it)")
LINE_TIMEOUT = 20.0
"""Seconds a node may take to print a line waited for."""
RUNNING_CPU = 0.1
"""CPU seconds a node uses once gdb let it run, which a halted node does not."""
LOAD_AT = 0x0800_4000  # away from the link base 0x00010000: gdb needs the offset
RUN = (
    "--native", "signal", "--wire", "signal.y=gain.x", "--set", "gain.k=0x20000",
    "--set", "signal.amplitude=3", "--seconds", "0.05",
)  # fmt: skip


@pytest.fixture(scope="module")
def gain(example_builds, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("gdb")
    elf = out / "gain.elf"
    shutil.copy(example_builds["gain"].elf, elf)
    image_from_elf(elf).write(out / "gain.hex")
    return out / "gain.hex"


@pytest.fixture
def nodes(tmp_path: Path) -> Iterator[Callable[..., Child]]:
    """Start `firmware-sim COMMAND ... --gdb 127.0.0.1:0` as a child process, its output in a
    log of the test's; each is stopped when the test ends."""
    numbers = itertools.count()
    with ExitStack() as stack:

        def start_node(*args: object) -> Child:
            command = [sys.executable, "-m", "firmware_sim", *map(str, args)]
            command += ["--gdb", "127.0.0.1:0"]
            log = tmp_path / f"node-{next(numbers)}.log"
            return stack.enter_context(Child.start(f"firmware-sim {args[0]}", command, log))

        yield start_node


def start(nodes: Callable[..., Child], *args: object) -> tuple[Child, str, str]:
    """A node waiting for gdb: it, its address and its add-symbol-file command."""
    node = nodes("run", *args)
    where = node.wait_for(r"gdb: listening on (127\.0\.0\.1:\d+)", LINE_TIMEOUT)[1]
    symbols = node.wait_for(r"gdb: (add-symbol-file \S+ -o 0x[0-9A-F]+)", LINE_TIMEOUT)[1]
    return node, where, symbols


def finish(node: Child, timeout: float = 60) -> tuple[int, str]:
    """The node's exit status once its run is over, and what it printed."""
    status = node.wait(timeout)
    return status, "\n".join(node.lines())


def gdb(where: str, *commands: str) -> str:
    """gdb-multiarch in batch mode on the node: what it printed."""
    argv = [str(GDB), "-batch", "-nx", "-ex", f"target remote {where}"]
    for command in commands:
        argv += ["-ex", command]
    result = subprocess.run(argv, capture_output=True, text=True, timeout=60, check=False)
    return result.stdout + result.stderr


def report_of(output: str) -> dict:
    return json.loads(output[output.index("{") :])


def test_gdb_breaks_in_a_module_reads_steps_watches_and_continues(gain, nodes):
    node, where, symbols = start(nodes, "--module", f"{gain}@0x{LOAD_AT:08X}", *RUN, "--json")
    assert symbols == f"add-symbol-file {gain.with_suffix('.elf')} -o 0x{LOAD_AT - 0x10000:X}"
    output = gdb(
        where,
        symbols,
        "break gain_cycle",
        "continue",
        "info registers a0 pc",
        "print *(int *)((struct pbo_context *)$a0)->ports[0]",
        "set $y = (int *)((struct pbo_context *)$a0)->ports[1]",
        "stepi",
        "info registers pc",
        "shell sleep 1",  # the target stays halted a while: its virtual clock must not move
        "delete 1",
        "watch *$y",
        "continue",
        "print *$y",
        "delete 2",
        "continue",
    )
    assert "Breakpoint 1, gain_cycle (ctx=0x3000" in output
    a0 = int(re.search(r"^a0\s+(0x[0-9a-f]+)", output, re.M).group(1), 16)
    pcs = [int(pc, 16) for pc in re.findall(r"^pc\s+(0x[0-9a-f]+)", output, re.M)]
    assert 0x3000_0000 <= a0 < 0x3001_0000  # the context in the task window (the argument)
    assert pcs[1] == pcs[0] + 4  # stepi: one RV32IM instruction
    assert LOAD_AT <= pcs[0] < LOAD_AT + 0x1000
    assert "$1 = 3" in output  # gain.x in its port buffer: signal's first ramp value
    assert re.search(r"Hardware watchpoint 2: \*\$y\s+Old value = 0\s+New value = 6", output)
    status, printed = finish(node)
    assert status == 0
    debugged = report_of(printed)
    module = f"{gain}@0x{LOAD_AT:08X}"
    plain = subprocess.run(
        [
            sys.executable,
            "-m",
            "firmware_sim",
            "run",
            "--module",
            module,
            *RUN,
            "--json",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    undebugged = report_of(plain.stdout)
    assert debugged["time"] == undebugged["time"] == pytest.approx(0.05)
    assert debugged["ports"] == undebugged["ports"]
    assert debugged["stats"] == undebugged["stats"]  # same cycles, instructions, busy time


def test_gdb_moves_pc_to_skip_an_instruction_jump_or_return_from_a_method(gain, nodes):
    node, where, symbols = start(nodes, "--module", f"{gain}@0x{LOAD_AT:08X}", *RUN, "--json")
    output = gdb(
        where,
        symbols,
        "break gain_cycle",
        "continue",
        "set $y = (int *)((struct pbo_context *)$a0)->ports[1]",
        "return 0",  # the first cycle returns before it writes y
        "info registers pc",
        "continue",
        "print *$y",
        "info registers pc",
        "set $pc = $pc + 4",
        "info registers pc",
        "stepi",
        "info registers pc",
        "set $pc = 0x20",  # not the module's code: refused
        "info registers pc",
        "jump gain_cycle",  # onto breakpoint 1: it halts there before the cycle runs
        "print *$y",
        "info registers pc",
        "return 0",  # the skipped instruction set up what the rest needs: leave the method
        "delete",
        "continue",
    )
    pcs = [int(pc, 16) for pc in re.findall(r"^pc\s+(0x[0-9a-f]+)", output, re.M)]
    assert pcs[0] == 0x1000_0000  # the trampoline: the method returns at once
    assert "$1 = 0" in output  # at the second cycle y is still unwritten
    assert pcs[2] == pcs[1] + 4 and pcs[3] == pcs[1] + 8
    assert "Could not write register \"pc\"; remote failure reply 'E01'" in output
    assert pcs[4] == pcs[3]
    assert output.count("Breakpoint 1, gain_cycle") == 3  # two cycles, then the jump
    assert "$2 = 0" in output and pcs[5] == pcs[1]
    status, printed = finish(node)
    assert status == 0, printed
    report = report_of(printed)
    assert report["stats"]["gain"]["state"] == "ON" and report["stats"]["gain"]["faults"] == 0
    assert report["ports"]["gain.y"] == 2 * report["ports"]["gain.x"]  # later cycles ran whole


def test_stepping_past_a_methods_return_halts_at_the_trampoline_then_in_the_next_call(gain, nodes):
    node, where, symbols = start(nodes, "--module", f"{gain}@0x{LOAD_AT:08X}", *RUN)
    output = gdb(
        where,
        symbols,
        "break gain_cycle",
        "continue",
        "delete",
        "next",
        "next",
        "next",  # past the last line: gdb single-steps the ret with a breakpoint on 0x10000000
        "info registers pc a0",
        "stepi",  # the trampoline's j . : on to the next guest call
        "info registers pc",
        "finish",
        "delete",
        "continue",
    )
    pcs = [int(pc, 16) for pc in re.findall(r"^pc\s+(0x[0-9a-f]+)", output, re.M)]
    a0 = int(re.search(r"^a0\s+(0x[0-9a-f]+)", output, re.M).group(1), 16)
    assert pcs[0] == 0x1000_0000 and a0 == 0  # gain_cycle returned PBO_OK
    assert LOAD_AT <= pcs[1] < LOAD_AT + 0x1000  # the first instruction of the next method
    assert re.search(r"gain_\w+ \(ctx=0x3000", output)  # ... which gdb names
    assert "Value returned is $1 = 0" in output  # finish: the method returned PBO_OK
    status, printed = finish(node)
    assert status == 0, printed


def running(node: Child, before: float, timeout: float = LINE_TIMEOUT) -> None:
    """Wait until the node has used RUNNING_CPU seconds of CPU more than `before`: halted, it
    waits for gdb without any."""
    deadline = time.monotonic() + timeout
    while node.cpu_seconds() - before < RUNNING_CPU:
        assert time.monotonic() < deadline, f"the node used no CPU in {timeout:g} s: it is halted"
        time.sleep(0.02)


def rsp(where: str) -> PacketConnection:
    host, port = where.split(":")
    return PacketConnection(socket.create_connection((host, int(port)), timeout=20))


def test_an_interrupt_halts_a_running_guest_and_a_vanished_gdb_lets_the_node_run_on(gain, nodes):
    node, where, _ = start(nodes, "--module", f"{gain}@0x{LOAD_AT:08X}", *RUN[:-1], "300")
    client = rsp(where)
    client.send("?")
    assert client.receive(timeout=20) == b"T05"  # halted on connection
    busy = node.cpu_seconds()
    client.send("c")
    running(node, busy)  # 300 s of virtual time take some seconds
    client.socket.sendall(b"\x03")
    stop = client.receive(timeout=20)
    assert stop is not None and stop.startswith(b"T02")  # SIGINT
    client.send("p20")  # pc: a guest instruction of gain
    assert (
        LOAD_AT
        <= int.from_bytes(bytes.fromhex(client.receive(timeout=20).decode()), "little")
        < LOAD_AT + 0x1000
    )
    client.close()  # gdb vanishes while the target is halted
    status, output = finish(node, timeout=120)
    assert status == 0
    assert "gdb: gdb disconnected; the node runs on" in output
    assert "ran 300.000 s of virtual time" in output


def test_a_listening_node_takes_gdb_between_jobs_for_a_module_that_arrived(gain, nodes):
    node = nodes(
        "listen", "--listen", "tcp-listen://127.0.0.1:0", "--native", "signal",
        "--wire", "signal.y=gain.x", "--set", "gain.k=0x20000", "--set", "signal.amplitude=3",
        "--elf", gain.with_suffix(".elf"), "--seconds", "60",
    )  # fmt: skip
    link = node.wait_for(r"--to (socket://127\.0\.0\.1:\d+)", LINE_TIMEOUT)[1]
    where = node.wait_for(r"gdb: listening on (127\.0\.0\.1:\d+)", LINE_TIMEOUT)[1]
    sent = subprocess.run(
        [sys.executable, "-m", "hexmigrate", "send", str(gain), "--to", link],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert sent.returncode == 0, sent.stderr
    symbols = node.wait_for(r"gdb: (add-symbol-file \S+ -o 0x[0-9A-F]+)", LINE_TIMEOUT)[1]
    output = gdb(where, symbols, "break gain_cycle", "continue", "info registers pc", "detach")
    assert "Breakpoint 1, gain_cycle (ctx=0x3000" in output
    node.wait_for(r"gdb: gdb detached; the node runs on", LINE_TIMEOUT)


def test_a_client_that_connects_to_gdb_and_says_nothing_does_not_halt_the_node(nodes):
    node = nodes(
        "listen", "--listen", "tcp-listen://127.0.0.1:0", "--native", "signal",
        "--set", "signal.amplitude=3", "--set", "signal.period_ms=100", "--seconds", "60",
    )  # fmt: skip
    link = node.wait_for(r"--to (socket://127\.0\.0\.1:\d+)", LINE_TIMEOUT)[1]
    host, port = node.wait_for(r"gdb: listening on (127\.0\.0\.1):(\d+)", LINE_TIMEOUT).groups()
    with socket.create_connection((host, int(port))) as silent:
        read = [sys.executable, "-m", "hexmigrate", "get", "signal.y", "--to", link]
        answered = subprocess.run(read, capture_output=True, text=True, timeout=60, check=False)
        assert answered.returncode == 0, answered.stderr  # the node was not halted for it
        node.wait_for(r"gdb: 127\.0\.0\.1:\d+ said nothing in 5 s; let go", LINE_TIMEOUT)
        assert silent.recv(1) == b""  # its connection closed
    assert "the node is halted" not in "\n".join(node.lines())


def test_a_gdb_build_keeps_its_locals_and_gdb_finds_its_source_where_the_node_says(nodes, tmp_path):
    """``python -m module_sdk.build --gdb`` (-Og -g3): after ``next`` gdb still prints ``ctx``
    (-Os has it optimized out), and the node's ``gdb: directory`` line lets gdb list the source
    the DWARF names relative to the build folder (issue 26, point 5)."""
    out = tmp_path / "build"
    assert build_main(["--gdb", "--out", str(out), str(EXAMPLES_DIR / "gain.c")]) == 0
    image_from_elf(out / "gain.elf").write(out / "gain.hex")
    node, where, symbols = start(nodes, "--module", f"{out / 'gain.hex'}@0x{LOAD_AT:08X}", *RUN)
    directory = node.wait_for(r"gdb: (directory \S+)", LINE_TIMEOUT)[1]
    assert directory == f"directory {out}"
    commands = ("break gain_cycle", "continue", "next", "print ctx", "print PBO_MAX_PORTS", "list")
    output = gdb(where, symbols, directory, *commands)
    assert "optimized out" not in output
    assert re.search(r"\$1 = \(struct pbo_context \*\) 0x[0-9a-f]+", output), output
    assert "$2 = 8" in output  # a macro of the SDK: -g3 keeps them (-g does not)
    assert "pbo_q16_mul" in output  # the listed source lines
    node.stop()
