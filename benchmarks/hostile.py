"""A longer hostile-input fuzz of a listening node process than the suite's.

Starts ``firmware-sim listen`` on ``tcp-listen://127.0.0.1:0`` with a flash file, installs the
SDK's ``gain`` example, then sends N hostile inputs, each on a connection of its own: random
bytes, and valid frames of both modes with hostile fields (a BEGIN of up to 4 GiB or at a load
address outside flash or over the installed module, a HEADER whose locations and init lie
outside any image, DATA for unknown transfers, END/COMMIT/RESUME/ABORT for unknown tids, RM of
absent modules, record lines that are not records, HTTP requests, a stream with no newline).
Then it reports the inputs tried, how many were refused (every answer a NAK), ignored (no
answer) or answered otherwise (an ACK of a harmless request, such as a BEGIN that fits), and
whether anything went wrong: the node exited, installed or removed a module, or the installed
module's bytes in the flash file changed. The node's peak RSS is its VmHWM.

Four more classes follow, each reporting crashes (a process that ended, a command that raised)
and hangs (past its deadline): the same hostile inputs to the C firmware on QEMU (`firmware-sim
qemu`) on its pty, each followed by a PING it must answer, its installed module unchanged; a
debugger's packets (random framed packets of every kind to the
node's gdb port, then a detach: the node must run on), a bridge's peers (strangers on an import
port sending random bytes and value frames under other keys, some numbered 2^32-1: the node
must keep answering, and the port take the real exporter's values), and hostile answers to the
host (``hexmigrate`` commands against a fake node answering escapes, floods, huge texts and
garbage: every command must end within its deadline and print no control character).

    python benchmarks/hostile.py [--inputs N] [--seed S]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import random
import socket
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path

from firmware_sim.bridge.value_message import bridge_key, encode_value, new_key
from firmware_sim.core.memory_map import FLASH_BASE
from firmware_sim.errors import QemuError
from firmware_sim.gdb.packets import PacketConnection
from firmware_sim.qemu.firmware_build import firmware_elf
from firmware_sim.qemu.flash_file import ensure_flash
from firmware_sim.qemu.machine import QemuNode, handshake
from firmware_sim.serving.node_process import NodeProcess
from hexmigrate import cli
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import HexmigrateError
from hexmigrate.image import ModuleImage
from hexmigrate.links import open_link
from hexmigrate.links.framing import frame
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.messages import (
    Abort,
    Ack,
    Begin,
    Commit,
    Data,
    End,
    Header,
    Message,
    Nak,
    PerformanceReport,
    Remove,
    Resume,
    decode,
    encode,
)
from hexmigrate.transfer.sender import Sender
from module_sdk.build import build_examples

QUIET = 0.2
"""Seconds a hostile connection is read after its last byte."""
ANSWER_LIMIT = 10.0
"""Seconds one input's answers are read for at most (a node that answers without end)."""
U32 = (1 << 32) - 1
PTY_RATE = 5000.0
"""Bytes per second QEMU's UART takes from a host at least (it took 8 kB/s here): a 100 kB
input is read for 20 s before the PING after it can be."""
REMOVAL = b"RM gain"
"""The installed module's removal, in an HTTP request's body: refused with the request on a
TCP node, but a valid command on a serial line, where a node without --trust obeys any."""
QEMU_FLASH_BASE = 0x2200_0000
"""Where QEMU virt's flash bank 1 (the C firmware's flash) starts: the flash file's offset 0."""


def hostile_input(rng: random.Random, module: int) -> bytes:
    """One hostile input; `module` is the installed module's load address."""
    kind = rng.randrange(4)
    if kind == 0:
        return rng.randbytes(rng.randrange(1, 2000))
    if kind == 1:
        return b"".join(
            frame(encode(message, text))
            for message, text in (_message(rng, module) for _ in range(rng.randrange(1, 8)))
        )
    if kind == 2:
        return rng.choice(
            [
                b"GET / HTTP/1.1\r\nHost: node\r\n\r\n",
                b"POST / HTTP/1.1\r\nContent-Length: 8\r\n\r\nRM gain\r\n",
                b":x\n" * rng.randrange(1, 100),
                b":10000000" + b"0" * rng.randrange(4000),
                b"BEGIN 1 " + b"n" * rng.randrange(1000, 100_000) + b" 4 0 0x0\n",
            ]
        )
    return b"\x00" + rng.randbytes(rng.randrange(1, 600)) + b"\x00"


def _message(rng: random.Random, module: int) -> tuple[Message, bool]:
    tid, text = rng.randint(0, U32), rng.random() < 0.5
    kind = rng.randrange(7)
    if kind == 0:
        size = rng.choice([rng.randint(1 << 20, U32), rng.randint(1, 4096)])
        base = rng.choice(
            [None, rng.randint(0, FLASH_BASE - 1), rng.randint(FLASH_BASE + (1 << 18), U32 - 1)]
        )
        return Begin(tid, "x", size, rng.randrange(65536), rng.randint(0, U32), base), text
    if kind == 1:
        return Begin(tid, "x", 256, 0, 0, module + 4 * rng.randrange(4)), text
    if kind == 2:
        locations = tuple(rng.randint(0, U32) for _ in range(rng.randrange(64)))
        return Header(tid, rng.randint(0, U32), locations), False
    if kind == 3:
        return Data(tid, rng.randint(0, U32), rng.randbytes(rng.randrange(1, 512))), False
    if kind == 4:
        return rng.choice([End(tid, rng.randint(0, U32)), Resume(tid), Abort(tid)]), text
    if kind == 5:
        return Commit(tid), text
    return Remove(rng.choice(["nothing", "x" * 200])), text


def peak_rss_mb(pid: int) -> float:
    status = Path(f"/proc/{pid}/status").read_text()
    line = next(line for line in status.splitlines() if line.startswith("VmHWM:"))
    return int(line.split()[1]) / 1024


def fuzz(node: NodeProcess, module: int, rng: random.Random, inputs: int) -> dict[str, int]:
    """Send `inputs` hostile inputs (fewer if the node exits); how each was answered."""
    counts = {"refused": 0, "ignored": 0, "answered": 0, "wrong": 0}
    for _ in range(inputs):
        data = hostile_input(rng, module)
        answers = [decode(raw) for raw in node.exchange(data, QUIET, ANSWER_LIMIT)]
        if any(isinstance(a, Ack) and a.text.startswith(("installed", "removed")) for a in answers):
            counts["wrong"] += 1
        elif not answers:
            counts["ignored"] += 1
        elif all(isinstance(a, Nak) for a in answers):
            counts["refused"] += 1
        else:
            counts["answered"] += 1
        if node.child.process.poll() is not None:
            break
    return counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--inputs", type=int, default=2000, help="hostile inputs to send")
    parser.add_argument("--seed", type=int, default=1, help="seed of the inputs")
    arguments = parser.parse_args()
    rng = random.Random(arguments.seed)
    with tempfile.TemporaryDirectory() as folder:
        image = image_from_elf({b.name: b for b in build_examples(Path(folder))}["gain"].elf)
        flash = Path(folder) / "flash.bin"
        options = ("--flash", str(flash), "--set", "gain.k=0x20000")
        with NodeProcess("tcp-listen://127.0.0.1:0", *options) as node:
            with open_link(node.url) as link:
                installed = Sender(link, "binary", timeout=10.0, retries=0).send(image)
            offset = installed.load_address - FLASH_BASE
            before = flash.read_bytes()[offset : offset + image.size]
            start = time.monotonic()
            counts = fuzz(node, installed.load_address, rng, arguments.inputs)
            alive = node.child.process.poll() is None
            intact = flash.read_bytes()[offset : offset + image.size] == before
            tried = sum(counts.values())
            print(
                f"{tried} hostile inputs in {time.monotonic() - start:.1f} s: "
                f"{counts['refused']} refused, {counts['ignored']} ignored, "
                f"{counts['answered']} answered harmlessly, "
                f"{counts['wrong']} installed or removed a module"
            )
            print(
                f"node alive: {alive}; installed module intact in flash: {intact}; "
                f"node peak RSS: {peak_rss_mb(node.pid):.1f} MiB"
            )
        more_classes(rng, arguments.inputs, image)


def gdb_packets(rng: random.Random, count: int) -> dict[str, int]:
    """`count` random framed packets to a listening node's gdb port (it halts once the client
    speaks), then a detach; the node must answer each and run on."""
    options = ("--native", "signal", "--gdb", "127.0.0.1:0")
    outcome = {"packets": 0, "unanswered": 0, "crashes": 0}
    with NodeProcess("tcp-listen://127.0.0.1:0", *options) as node:
        host, port = node.wait_for(r"gdb: listening on (127\.0\.0\.1):(\d+)").groups()
        client = PacketConnection(socket.create_connection((host, int(port)), timeout=10))
        with contextlib.closing(client):
            for _ in range(count):
                client.send(_gdb_packet(rng))
                outcome["packets"] += 1
                if client.receive(timeout=10) is None:
                    outcome["unanswered"] += 1
                if node.child.process.poll() is not None:
                    break
            client.send("D")
            with open_link(node.url) as link:
                Sender(link, "binary", timeout=5.0, retries=2).ping()
        outcome["crashes"] = int(node.child.process.poll() is not None)
    return outcome


def _gdb_packet(rng: random.Random) -> str:
    numbers = [0, 1, FLASH_BASE, 0x20000000, 0xFFFFFFFF, 1 << 40, rng.getrandbits(36)]
    number = f"{rng.choice(numbers):x}"
    kind = rng.choice("mMgGpPZzqH?T")
    payload = rng.randbytes(rng.randrange(0, 40)).hex()
    return rng.choice(
        [
            f"{kind}{number},{rng.choice(numbers):x}:{payload}",
            f"{kind}{payload}",
            "".join(chr(rng.randrange(32, 256)) for _ in range(rng.randrange(1, 60))),
        ]
    ).lstrip("cCsSDkv")  # not a resume, detach or kill: those end the fuzz


def bridge_peers(rng: random.Random, count: int, image: ModuleImage) -> dict[str, int]:
    """Strangers on an import port (into gain's input, `image`): random bytes and values under
    other keys; then the real exporter's value must still come through, and the node answer."""
    outcome = {"inputs": 0, "crashes": 0, "poisoned": 0}
    options = ("--set", "gain.k=0x20000", "--lock-step")
    with NodeProcess("tcp-listen://127.0.0.1:0", *options) as node, open_link(node.url) as link:
        sender = Sender(link, "binary", timeout=5.0, retries=2)
        sender.send(image)
        control = NodeControl(sender)
        url = control.import_port(1, "gain.x", "tcp-listen://127.0.0.1:0")
        where, key = bridge_key(url)
        for _ in range(count):
            with contextlib.suppress(OSError, ValueError), open_link(where) as stranger:
                stranger.send(
                    rng.choice(
                        [
                            rng.randbytes(rng.randrange(1, 200)),
                            encode_value(new_key(), 1, U32, 0.0, 0.0, bytes(4)),
                            encode_value(new_key(), 1, rng.getrandbits(32), 0.0, 0.0, bytes(4)),
                        ]
                    )
                )
            outcome["inputs"] += 1
        with open_link(where) as exporter:
            exporter.send(encode_value(key, 1, 1, 0.0, 0.0, (7).to_bytes(4, "little")))
        try:
            control.advance(0.01, {1: 1})
        except HexmigrateError:
            outcome["poisoned"] = 1
        outcome["crashes"] = int(node.child.process.poll() is not None)
    return outcome


COMMANDS = (["ping"], ["ls"], ["ps"], ["get", "gain.y"], ["stop", "gain"], ["logs", "gain"])
EVIL = ("\x1b]0;pwned\x07", "\x1b[2J", "\r", "\r\nerror: forged", "\x00", "A" * 100_000)


def hostile_answers(rng: random.Random, count: int) -> dict[str, int]:
    """`count` hexmigrate commands against a fake node answering hostile texts, garbage or a
    flood; each must end within its deadline (2 tries of 0.5 s, and 1 s of slack) and print no
    control character."""
    outcome = {"commands": 0, "crashes": 0, "hangs": 0, "escapes printed": 0}
    for _ in range(count):
        behaviour = rng.choice(["text", "garbage", "flood"])
        text = "".join(rng.choice(EVIL) for _ in range(rng.randrange(1, 4)))
        with _fake_node(behaviour, text) as url:
            out, err = io.StringIO(), io.StringIO()
            started = time.monotonic()
            try:
                with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                    command = [*rng.choice(COMMANDS), "--to", url]
                    cli.main([*command, "--timeout", "0.5", "--retries", "1"])
            except Exception:
                outcome["crashes"] += 1
            if time.monotonic() - started > 2 * 0.5 + 1.0:  # its 2 tries, and slack
                outcome["hangs"] += 1
        printed = out.getvalue() + err.getvalue()
        if not all(line.isprintable() for line in printed.splitlines()):
            outcome["escapes printed"] += 1
        outcome["commands"] += 1
    return outcome


@contextlib.contextmanager
def _fake_node(behaviour: str, text: str) -> Iterator[str]:
    """A fake node on a thread: it answers each request with `text` in a refusal (``text``),
    with garbage (``garbage``), or pushes reports without end (``flood``)."""
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(0.1)
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            try:
                client, _ = server.accept()
            except OSError:
                continue
            with client:
                client.settimeout(0.05)
                while not stop.is_set():
                    try:
                        data = client.recv(65536)
                    except TimeoutError:
                        data = b"?"
                    except OSError:
                        break
                    if not data:
                        break
                    if behaviour == "flood":
                        reply = PerformanceReport(1, 1, "leftover=1")
                        payload = frame(encode(reply, False)) * 64
                    elif behaviour == "garbage":
                        payload = os.urandom(512)
                    else:
                        payload = frame(encode(Nak(0, 0, text, fatal=True), False))
                    with contextlib.suppress(OSError):
                        client.sendall(payload)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"socket://127.0.0.1:{server.getsockname()[1]}"
    finally:
        stop.set()
        server.close()
        thread.join(timeout=5)


def qemu_node(rng: random.Random, count: int, image: ModuleImage) -> dict[str, int]:
    """The same hostile inputs to the C firmware on QEMU (`firmware-sim qemu`'s node), one
    after another on its pty, each followed by a PING that must be answered; the
    installed module must stay listed and its bytes in the flash file unchanged."""
    outcome = {"inputs": 0, "unanswered": 0, "crashes": 0, "module changed": 0}
    with tempfile.TemporaryDirectory() as folder:
        flash = ensure_flash(Path(folder) / "qemu.img")
        with QemuNode(firmware_elf(), flash) as qemu:
            with open_link(qemu.start()) as link:
                sender = Sender(link, "hex", timeout=10.0, retries=0)
                installed = sender.send(image)
            offset = installed.load_address - QEMU_FLASH_BASE
            before = flash.read_bytes()[offset : offset + image.size]
            descriptor = os.open(qemu.url, os.O_RDWR | os.O_NOCTTY)
            try:
                for _ in range(count):
                    data = hostile_input(rng, installed.load_address)
                    if REMOVAL in data:  # a serial line's valid command: obeyed, as it should be
                        continue
                    os.write(descriptor, data + b"\n")
                    outcome["inputs"] += 1
                    outcome["unanswered"] += not _answers(descriptor, len(data))
                    if not qemu.running():
                        break
            finally:
                os.close(descriptor)
            outcome["crashes"] = int(not qemu.running())
            with open_link(qemu.url) as link:
                listed = Sender(link, "hex", timeout=5.0, retries=2).modules()
            after = flash.read_bytes()[offset : offset + image.size]
            outcome["module changed"] = int(after != before or len(listed) != 1)
    return outcome


def _answers(descriptor: int, sent: int) -> bool:
    """Whether the node on the pty `descriptor` answers a PING after an input of `sent` bytes
    (which the UART carries at PTY_RATE first), as a host would reach it: by a line, and if the
    input left a binary frame open (which swallows lines until its closing 0x00), after a
    delimiter that closes it, as a host's next binary message would."""
    for _ in range(2):
        try:
            handshake(descriptor, ANSWER_LIMIT / 2 + sent / PTY_RATE)
            return True
        except QemuError:
            os.write(descriptor, b"\x00")
    return False


def more_classes(rng: random.Random, inputs: int, image: ModuleImage) -> None:
    """The debugger's, the bridge peers', the host's and the C firmware's classes."""
    for name, outcome in (
        ("gdb packets", gdb_packets(rng, inputs // 4)),
        ("bridge peers", bridge_peers(rng, inputs // 10, image)),
        ("hostile answers to the host", hostile_answers(rng, inputs // 20)),
        ("the C firmware on QEMU", qemu_node(rng, inputs // 10, image)),
    ):
        print(f"{name}: " + ", ".join(f"{value} {key}" for key, value in outcome.items()))


if __name__ == "__main__":
    main()
