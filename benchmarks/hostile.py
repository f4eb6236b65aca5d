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

    python benchmarks/hostile.py [--inputs N] [--seed S]
"""

from __future__ import annotations

import argparse
import random
import tempfile
import time
from pathlib import Path

from firmware_sim.core.memory_map import FLASH_BASE
from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.elf import image_from_elf
from hexmigrate.links import open_link
from hexmigrate.links.framing import frame
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


if __name__ == "__main__":
    main()
