"""Power cuts on QEMU: the node is killed (SIGKILL, QEMU's flash file keeps what the chip held
at that instant) at chosen points of a transfer, of its commit and of a removal, then restarted
on the same flash file. It must hold the old module or the new one, never a half one: the C
node's own listing and the directory read by the Python node's decoder agree, and every image
the directory names is whole (its CRC-32). Then a transfer must work again on that flash (the
remains of the cut one are erased on reuse).
"""

from __future__ import annotations

import random
import time
import zlib

import pytest

from hexmigrate.image import FLASH_BLOCK_SIZE, ModuleImage
from hexmigrate.links import open_link
from hexmigrate.records import Record, RecordType
from hexmigrate.transfer.messages import (
    Ack,
    Begin,
    Commit,
    End,
    HexLine,
    Message,
    Ping,
    Remove,
    decode,
)
from hexmigrate.transfer.messages import encode as encode_message
from hexmigrate.transfer.sender import Sender
from tests.firmware.flash_image import FLASH_BASE, committed

SECTOR = 256 * 1024
TID = 4242
RECORD = 16
CUTS = [*random.Random(28).sample(range(80), 3), 0, -3, -2, -1]
"""During which message after BEGIN the power goes (0: the first header line; -2: END, -1:
COMMIT; gain has 87): the same drawn points on every run, plus both ends (the conformance
suite's power cuts draw more, at random moments)."""
DELAYS = (0.0, 0.001, 0.003, 0.02)
"""How long the firmware may work on that message before the cut."""
SETTLE_TIMEOUT = 10.0
COMMIT_STEP = 0.003
COMMIT_STEPS = 100


def transfer_lines(image: ModuleImage, load_base: int) -> list[Message]:
    """The messages after BEGIN of a hex-mode transfer, as `Sender` sends them in order: the
    header's 07 and 08 lines, each block's 04 line and data lines, END and COMMIT."""
    header = [Record.pointer(RecordType.OFFSET_FUNCTION_POINTER, at) for at in image.relocations]
    header.append(Record.pointer(RecordType.MODULE_INIT_POINTER, image.init))
    lines: list[Message] = [HexLine(record.encode()) for record in header]
    for offset in range(0, image.size, FLASH_BLOCK_SIZE):
        address = image.link_base + offset
        upper = (address >> 16).to_bytes(2, "big")
        lines.append(HexLine(Record(RecordType.EXTENDED_LINEAR_ADDRESS, 0, upper).encode()))
        for start in range(offset, min(offset + FLASH_BLOCK_SIZE, image.size), RECORD):
            here = image.link_base + start
            data = image.data[start : start + RECORD]
            lines.append(HexLine(Record(RecordType.DATA, here & 0xFFFF, data).encode()))
    crc = zlib.crc32(image.relocate(load_base))
    return [*lines, End(TID, crc), Commit(TID)]


def settle(link) -> None:
    """Wait until the firmware has handled everything sent so far: a PING is answered after
    the lines before it."""
    link.send(encode_message(Ping(), True))
    deadline = time.monotonic() + SETTLE_TIMEOUT
    while time.monotonic() < deadline:
        if (link.receive(0.1) or b"").startswith(b"PONG"):
            return
    raise AssertionError(f"the firmware did not answer PING in {SETTLE_TIMEOUT} s")


def cut_transfer(node, image: ModuleImage, cut: int, delay: float) -> None:
    """BEGIN and the transfer's messages before message `cut` (an index of `transfer_lines`),
    handled; then message `cut`, `delay` s for the firmware to work on it, and the power cut."""
    with open_link(node.url) as link:
        begin = Begin(TID, image.name, image.size, len(image.relocations), image.link_base)
        link.send(encode_message(begin, True))
        answer = decode(link.receive(5.0) or b"", checked=True)
        assert isinstance(answer, Ack) and answer.text == "begun", answer
        messages = transfer_lines(image, answer.value)
        for message in messages[: cut % len(messages)]:
            link.send(encode_message(message, True))
        settle(link)
        link.send(encode_message(messages[cut], True))
        time.sleep(delay)
        node.kill()


def check_after_restart(boot, flash_file, images, allowed, reuse: bool = True) -> None:
    """The node restarted on the flash lists one of `allowed` (name, address) sets, as its
    directory does, every image whole; and (`reuse`) it takes a module again."""
    node = boot(flash_file)
    with open_link(node.url) as link:
        sender = Sender(link, "hex", timeout=2.0)
        listed = {(m.name, m.address) for m in sender.modules()}
        directory = committed(flash_file)
        assert listed == {(name, entry.load_address) for name, entry in directory.items()}
        assert listed in allowed, listed
        if reuse:
            sender.send(images["moving_average"])
            assert "moving_average" in {m.name for m in sender.modules()}
    node.stop()
    assert not reuse or "moving_average" in committed(flash_file)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("cut", CUTS[:-1])
def test_a_cut_transfer_leaves_no_module(boot, flash_file, images, cut):
    cut_transfer(boot(flash_file), images["gain"], cut, DELAYS[cut % len(DELAYS)])
    check_after_restart(boot, flash_file, images, [set()])


@pytest.mark.timeout(120)
@pytest.mark.parametrize("installed", [0, 1, 2])
def test_a_cut_commit_leaves_the_old_module_or_the_whole_new_one(
    boot, flash_file, images, installed
):
    """The power goes 0, 3, 6, ... ms into COMMIT, until a cut comes late enough to find the
    new module committed: every earlier cut left the old state. With 2 modules installed
    before, both directory slots are used and the commit goes through the scratch sector."""
    node = boot(flash_file)
    with open_link(node.url) as link:
        for _ in range(installed):
            Sender(link, "hex").send(images["gain"])
    node.stop()
    before = {(name, entry.load_address) for name, entry in committed(flash_file).items()}
    after = {("gain", FLASH_BASE + installed % 2 * SECTOR)}
    for step in range(COMMIT_STEPS):
        trial = flash_file.with_name(f"trial-{step}.img")
        trial.write_bytes(flash_file.read_bytes())
        cut_transfer(boot(trial), images["gain"], -1, step * COMMIT_STEP)
        done = after <= {(name, entry.load_address) for name, entry in committed(trial).items()}
        check_after_restart(boot, trial, images, [before, after], reuse=done)
        if done:
            return
    raise AssertionError(f"no cut within {COMMIT_STEPS * COMMIT_STEP} s found the commit done")


@pytest.mark.timeout(120)
@pytest.mark.parametrize("delay", DELAYS)
def test_a_cut_removal_leaves_the_module_or_nothing(boot, flash_file, images, delay):
    node = boot(flash_file)
    with open_link(node.url) as link:
        Sender(link, "hex").send(images["gain"])
        settle(link)
        link.send(encode_message(Remove("gain"), True))
        time.sleep(delay)
        node.kill()
    check_after_restart(boot, flash_file, images, [set(), {("gain", FLASH_BASE)}])
