"""The C firmware on QEMU virt, driven by the real ``hexmigrate`` over a pty: it boots, answers
ping, installs the SDK's example modules, lists and removes them, keeps them across a restart
on the same flash file, and writes the Python node's directory bytes (tests/firmware/
flash_image.py reads them with the Python node's own decoder).

Every QEMU a test starts is stopped by its fixture; every wait is bounded.
"""

from __future__ import annotations

import os
import pty
import re
import signal
import subprocess
import sys
import zlib
from pathlib import Path

import pytest

from commandline import SHOWN
from commandline.children import Child
from firmware_sim.cli.qemu_command import startup_lines
from firmware_sim.errors import FlashError, QemuError
from firmware_sim.qemu.flash_file import ensure_flash
from firmware_sim.qemu.machine import QemuNode, handshake
from hexmigrate.elf import image_from_elf
from hexmigrate.links import open_link
from hexmigrate.links.listening import CONNECT_URL
from hexmigrate.transfer.messages import Commit, Nak, PboTable, encode
from hexmigrate.transfer.sender import Sender
from module_sdk.build import build_module
from tests.disk import small_disk
from tests.firmware.flash_image import FLASH_BASE, committed
from tests.firmware_sim.host_side import CLI_TIMEOUT, hexmigrate, hexmigrate_refused

SECTOR = 256 * 1024
"""QEMU virt's flash erase sector: the firmware places each module at a sector boundary."""


@pytest.mark.timeout(30)
def test_the_firmware_boots_and_answers_ping(boot, flash_file):
    node = boot(flash_file)
    assert node.pong.startswith("node: 0 module(s), ")
    assert node.pong.endswith("qemu-virt firmware")
    said = hexmigrate("ping", "--to", node.url, "--mode", "hex")
    assert said.startswith("node: 0 module(s), 129024 of 131072 flash blocks free")


@pytest.mark.timeout(60)
def test_send_ls_and_rm_with_the_real_hexmigrate(boot, flash_file, example_hex):
    node = boot(flash_file)
    for name in ("gain", "moving_average"):
        sent = hexmigrate("send", example_hex[name], "--to", node.url, "--mode", "hex")
        assert f"module {name} installed at 0x" in sent
    listing = [
        line.split()[:4]
        for line in hexmigrate("ls", "--to", node.url, "--mode", "hex").splitlines()
    ]
    assert listing == [
        ["gain", f"0x{FLASH_BASE:08X}", "1120", "bytes"],
        ["moving_average", f"0x{FLASH_BASE + SECTOR:08X}", "1120", "bytes"],
    ]  # fmt: skip
    removed = hexmigrate("rm", "moving_average", "--to", node.url, "--mode", "hex")
    assert removed == f"removed moving_average from {node.url}\n"
    assert hexmigrate("ls", "--to", node.url, "--mode", "hex").split()[0] == "gain"
    refused = hexmigrate_refused("rm", "moving_average", "--to", node.url, "--mode", "hex")
    assert "the node refused: no module named 'moving_average'" in refused
    assert set(committed(flash_file)) == {"gain"}


@pytest.mark.timeout(60)
def test_the_modules_survive_a_restart_on_the_same_flash(boot, flash_file, images):
    first = boot(flash_file)
    with open_link(first.url) as link:
        sender = Sender(link, "hex")
        sender.send(images["gain"])
        sender.send(images["moving_average"])
    first.stop()
    entries = committed(flash_file)
    assert sorted(entries) == ["gain", "moving_average"]
    assert entries["gain"].init_address == FLASH_BASE + images["gain"].init - 0x10000

    second = boot(flash_file)
    assert second.pong.startswith("node: 2 module(s), ")
    with open_link(second.url) as link:
        sender = Sender(link, "hex")
        listed = sender.modules()
        assert listed == (  # the CRC-32 of each image as its directory entry holds it
            ("gain", FLASH_BASE, 1120, zlib.crc32(images["gain"].relocate(FLASH_BASE))),
            (
                "moving_average",
                FLASH_BASE + SECTOR,
                1120,
                zlib.crc32(images["moving_average"].relocate(FLASH_BASE + SECTOR)),
            ),
        )
        result = sender.send(images["gain"])  # a resend replaces it, the name stays listed once
        assert [m.name for m in sender.modules()] == ["moving_average", "gain"]
    assert result.load_address == FLASH_BASE + 2 * SECTOR
    assert sorted(committed(flash_file)) == ["gain", "moving_average"]


@pytest.mark.timeout(60)
def test_hexmigrate_in_its_default_binary_mode_pings_sends_lists_and_removes(
    boot, flash_file, example_hex
):
    node = boot(flash_file)
    assert hexmigrate("ping", "--to", node.url).startswith("node: 0 module(s), ")
    sent = hexmigrate("send", example_hex["gain"], "--to", node.url)
    assert f"module gain installed at 0x{FLASH_BASE:08X}" in sent
    assert hexmigrate("ls", "--to", node.url).split()[:4] == [
        "gain", f"0x{FLASH_BASE:08X}", "1120", "bytes"
    ]  # fmt: skip
    assert set(committed(flash_file)) == {"gain"}
    assert hexmigrate("rm", "gain", "--to", node.url) == f"removed gain from {node.url}\n"
    with open_link(node.url) as link:  # a binary request's refusal: binary, the Python words
        link.send(encode(Commit(5), False))
        refusal = Nak(5, 0, "unknown transfer 5: send BEGIN first", fatal=True)
        assert link.receive(5.0) == encode(refusal, False)
    assert committed(flash_file) == {}


@pytest.mark.timeout(30)
def test_control_requests_are_answered_and_a_missing_feature_refused_by_name(boot, flash_file):
    node = boot(flash_file)
    with open_link(node.url) as link:
        link.send(b"PS 77")
        assert link.receive(5.0) == encode(PboTable(77, ""), True)
        link.send(b"ADVANCE 78 1000")
        refusal = (
            "ADVANCE refused: this node runs on the real-time clock: the firmware has no "
            "lock-step time"
        )
        assert link.receive(5.0) == encode(Nak(78, 0, refusal, fatal=True), True)
        link.send(b"EXPORT 79 1 100 gain.y raw socket://127.0.0.1:9")
        assert link.receive(5.0).startswith(b"NAK 79 0 FATAL EXPORT refused: this node has no ")
        link.send(b"LS *00")
        assert link.receive(5.0).startswith(b"NAK 0 0 RETRY bad message: expected checksum")


@pytest.mark.timeout(60)
def test_a_second_node_on_a_running_nodes_flash_file_is_refused(boot, flash_file, firmware):
    first = boot(flash_file)
    second = QemuNode(firmware, flash_file)
    with pytest.raises(FlashError, match="expected a file no other node runs on"):
        second.start()
    assert not second.running()  # QEMU never started on it
    assert hexmigrate("ping", "--to", first.url).startswith("node: 0 module(s)")
    first.kill()  # a power cut frees the file as a stop does
    assert boot(flash_file).pong.startswith("node: 0 module(s)")


@pytest.mark.timeout(60)
def test_firmware_sim_qemu_prints_the_listening_line_and_stops_on_sigint(tmp_path, firmware):
    flash = tmp_path / "node.img"
    command = [sys.executable, "-m", "firmware_sim", "qemu", "--flash", str(flash)]
    with Child.start("firmware-sim qemu", command, tmp_path / "qemu.log") as child:
        url = child.wait_for(CONNECT_URL, CLI_TIMEOUT)[1]
        assert child.lines()[0] == (
            f"listening on {url} (connect with: hexmigrate send FILE.hex --to {url})"
        )
        assert hexmigrate("ping", "--to", url, "--mode", "hex").startswith("node: 0 module(s)")
        child.stop()
        assert child.process.returncode == 0
        assert child.lines()[-1] == "stopped"
    assert flash.stat().st_size == 32 * 1024 * 1024


@pytest.mark.timeout(60)
def test_a_qemu_that_ends_by_itself_is_an_error_quoting_what_it_said(tmp_path, firmware):
    command = [sys.executable, "-m", "firmware_sim", "qemu"]  # its log is a temporary file
    with Child.start("firmware-sim qemu", command, tmp_path / "qemu.log") as child:
        child.wait_for(CONNECT_URL, CLI_TIMEOUT)
        (qemu,) = (
            Path(f"/proc/{child.process.pid}/task/{child.process.pid}/children").read_text().split()
        )
        os.kill(int(qemu), signal.SIGTERM)
        assert child.wait() == 1
    assert re.fullmatch(
        r"error: QEMU ended by itself \(exit status 0\); it said: qemu-system-riscv32: "
        r"terminating on signal 15 from pid \d+ .*",
        child.lines()[-1],
    )


def test_a_flash_file_the_disk_cannot_hold_is_an_error_and_leaves_no_part(tmp_path, firmware):
    flash = tmp_path / "node.img"
    command = [sys.executable, "-m", "firmware_sim", "qemu", "--flash", str(flash)]
    done = subprocess.run(
        command, **small_disk(1 << 20), capture_output=True, text=True, timeout=CLI_TIMEOUT
    )
    assert done.returncode == 1
    assert done.stderr == (
        f"error: flash file {flash}: cannot write an erased one (33554432 bytes): File too large\n"
    )
    assert list(tmp_path.iterdir()) == []  # neither the file nor the part written


def test_the_handshake_names_what_it_heard_when_no_pong_comes():
    master, slave = pty.openpty()
    try:
        os.write(master, b"some noise\n")
        with pytest.raises(QemuError, match=r"did not answer PING in 0.2 s \(heard: some noise\)"):
            handshake(slave, 0.2)
    finally:
        os.close(master)
        os.close(slave)


def test_what_the_firmware_said_at_its_start_is_shown_escaped_and_cut(tmp_path):
    """A firmware of the user's (--firmware) or a broken one may send escape sequences and
    floods before its PONG: the command shows them as data, never as terminal commands."""
    heard = ["refresh-node banner", "\x1b[2Jcleared", "x" * 5000]
    lines = startup_lines("node: 0 module(s)\x1b]0;title\x07", heard, tmp_path / "f.img")
    assert lines[0].startswith("qemu: node: 0 module(s)\\x1b]0;title\\x07; flash ")
    assert lines[1] == "qemu: \\x1b[2Jcleared"
    assert lines[2].endswith(f"... ({5000 - SHOWN} more characters)")
    assert len(lines) == 3 and all(line.isprintable() for line in lines)


@pytest.mark.timeout(60)
def test_a_module_whose_image_was_damaged_is_skipped_at_boot(boot, flash_file, images):
    node = boot(flash_file)
    with open_link(node.url) as link:
        Sender(link, "hex").send(images["gain"])
    node.stop()
    flash = bytearray(flash_file.read_bytes())
    flash[100] ^= 0x01  # one bit of gain's code, at the start of the flash
    flash_file.write_bytes(flash)

    again = boot(flash_file)
    assert again.heard[0] == (
        "boot: skipped module 'gain': the image's CRC-32 is not the directory's"
    )
    assert again.pong.startswith("node: 0 module(s), ")


@pytest.mark.timeout(60)
@pytest.mark.parametrize("mode", ["binary", "hex"])
def test_a_signed_module_sent_with_a_key_installs_on_a_node_that_trusts_none(
    boot, flash_file, example_hex, tmp_path, mode
):
    """The node answers CHALLENGE and AUTH as a node that trusts no key (it guards nothing)
    and takes the signed module's signature area (09 lines, or binary mode's SIGNATURE); its
    directory records version 0, as the Python node's does when it trusts no key."""
    key, signed = tmp_path / "key.pem", tmp_path / "gain.signed.hex"
    hexmigrate("keygen", "-o", key)
    hexmigrate("sign", example_hex["gain"], "--key", key, "--version", "1.2.3", "-o", signed)
    node = boot(flash_file)
    sent = hexmigrate("send", signed, "--to", node.url, "--mode", mode, "--key", key)
    assert "module gain installed at 0x22000000" in sent
    node.stop()
    assert committed(flash_file)["gain"].version == 0


@pytest.mark.timeout(60)
def test_a_flash_file_whose_name_holds_a_comma_is_the_flash(boot, tmp_path, example_hex):
    """QEMU reads a comma as the end of an option's value: a name such as
    ``node,readonly=on.img`` set an option of its own, and the node never answered."""
    flash = ensure_flash(tmp_path / "node,readonly=on.img")
    node = boot(flash)
    hexmigrate("send", example_hex["gain"], "--to", node.url, "--quiet")
    assert set(committed(flash)) == {"gain"}


MODULE = """
#include "pbo_module.h"
static int32_t ok(struct pbo_context *ctx) { (void)ctx; return PBO_OK; }
%(code)s
static const struct pbo_descriptor descriptor PBO_DESCRIPTOR = {
    .magic = PBO_MAGIC, .abi_version = PBO_ABI_VERSION, .port_count = 1, .name = "%(name)s",
    .ports = {{"y", PBO_PORT_OUT, PBO_SCALAR, 4, 1, 1}},
    .init = ok, .on = ok, .cycle = cycle, .off = ok, .kill = ok, .error = ok, .clear = ok,
};
PBO_MODULE(descriptor)
"""
SHORT = "static int32_t cycle(struct pbo_context *ctx) { *(int32_t *)ctx->ports[0] = 1; return 0; }"
LONG = """
static int32_t cycle(struct pbo_context *ctx)
{
    int32_t sum = 0; /* 4242 the long way (2121 x 3 - 2121): more code before the descriptor */
    for (volatile int32_t i = 0; i < 4242; i++) {
        sum += (i & 1) ? 3 : -1;
    }
    *(int32_t *)ctx->ports[0] = sum;
    return PBO_OK;
}
"""


@pytest.mark.timeout(60)
def test_a_module_programmed_after_another_was_removed_runs_its_own_code(
    boot, flash_file, tmp_path
):
    """QEMU's flash model keeps its translations of code that ran after the chip is erased and
    programmed again: a module placed where a removed one had run would run the removed one's
    init (its descriptor looked for at the old offset: ERR_ABI) and code. The firmware gives
    such sectors out again only after a restart (board_code_reusable)."""
    files = {}
    for name, code in (("short", SHORT), ("long", LONG)):
        source = tmp_path / f"{name}.c"
        source.write_text(MODULE % {"code": code, "name": name})
        files[name] = tmp_path / f"{name}.hex"
        image_from_elf(build_module(source, tmp_path / name).elf).write(files[name])
    node = boot(flash_file)
    hexmigrate("send", files["short"], "--to", node.url)
    hexmigrate("rm", "short", "--to", node.url)
    sent = hexmigrate("send", files["long"], "--to", node.url)
    assert f"module long installed at 0x{FLASH_BASE + SECTOR:08X}" in sent
    assert hexmigrate("get", "long.y", "--to", node.url).strip() == "long.y=4242"
    node.stop()
    node = boot(flash_file)  # a restart: every free sector may take code again
    hexmigrate("send", files["short"], "--to", node.url)
    second = hexmigrate("ls", "--to", node.url).splitlines()[1]
    assert second.split()[:2] == ["short", f"0x{FLASH_BASE:08X}"]
