"""A debugger's packets cannot end or freeze a node: every packet kind the stub knows, framed
right but with addresses, lengths and payloads at and past every boundary, against a real node
process halted for gdb; each is answered (an error where it is malformed), and the node then
runs its module to the end. Memory writes reach the node's SRAM only, never its flash: a
debugger cannot rewrite an installed module's code or the flash directory."""

from __future__ import annotations

import socket
import subprocess
import sys
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from commandline.children import Child
from firmware_sim.core.memory_map import FLASH_BASE, SRAM_BASE
from firmware_sim.gdb.packets import PacketConnection
from hexmigrate.signing import keys
from tests.firmware_sim.test_gdb import LINE_TIMEOUT, gain  # noqa: F401 (a fixture)

EDGES = [0, 1, FLASH_BASE - 1, FLASH_BASE, FLASH_BASE + 0x3FFFF, SRAM_BASE - 4, SRAM_BASE,
         SRAM_BASE + 0x1FFFC, SRAM_BASE + 0x20000, 0x7FFFFFFF, 0xFFFFFFFC, 0xFFFFFFFF,
         1 << 32, 1 << 64]  # fmt: skip
numbers = st.one_of(st.sampled_from(EDGES), st.integers(0, 1 << 70))
hexes = st.one_of(numbers.map(lambda n: f"{n:x}"), st.sampled_from(["", "-1", "zz", "0x10"]))
payloads = st.one_of(
    st.binary(max_size=64).map(bytes.hex),
    st.text("0123456789abcdefxyz", max_size=33),
)
packets = st.one_of(
    st.builds(lambda a, n: f"m{a},{n}", hexes, hexes),
    st.builds(lambda a, n, d: f"M{a},{n}:{d}", hexes, hexes, payloads),
    st.builds(lambda d: f"G{d}", payloads),
    st.builds(lambda r: f"p{r}", hexes),
    st.builds(lambda r, v: f"P{r}={v}", hexes, hexes),
    st.builds(lambda k, a, n: f"Z{k},{a},{n}", st.sampled_from("0123459"), hexes, hexes),
    st.builds(lambda k, a, n: f"z{k},{a},{n}", st.sampled_from("0123459"), hexes, hexes),
    st.builds(lambda o, n: f"qXfer:features:read:target.xml:{o},{n}", hexes, hexes),
    st.sampled_from(["g", "?", "qSupported", "qC", "vCont?", "Hg0", "T1", "X0,0:", "qRcmd,00"]),
    st.text(st.characters(max_codepoint=255), max_size=40).filter(
        lambda t: t[:1] not in ("c", "s", "D", "k", "v", "C", "S")
    ),
)


@pytest.fixture
def halted(gain, tmp_path) -> Iterator[tuple[Child, PacketConnection]]:  # noqa: F811
    """A node that runs gain for 0.2 s, halted for gdb before it starts, and an RSP client."""
    command = [sys.executable, "-m", "firmware_sim", "run", "--module", str(gain), "--native",
               "signal", "--wire", "signal.y=gain.x", "--set", "gain.k=0x20000",
               "--seconds", "0.2", "--gdb", "127.0.0.1:0"]  # fmt: skip
    with Child.start("firmware-sim run", command, tmp_path / "node.log") as node:
        host, port = node.wait_for(r"gdb: listening on (127\.0\.0\.1):(\d+)", LINE_TIMEOUT).groups()
        client = PacketConnection(socket.create_connection((host, int(port)), timeout=20))
        try:
            yield node, client
        finally:
            client.close()


def ask(client: PacketConnection, packet: str) -> bytes:
    client.send(packet)
    answer = client.receive(timeout=10)
    assert answer is not None, f"no answer to {packet!r}"
    return answer


@pytest.mark.slow
def test_malformed_packets_are_answered_and_the_node_runs_on(halted) -> None:
    node, client = halted

    @settings(
        max_examples=150,
        derandomize=True,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(packets)
    def one(packet: str) -> None:
        ask(client, packet)
        assert node.process.poll() is None, "\n".join(node.lines()[-20:])

    one()
    client.send("D")
    assert node.wait(60) == 0, "\n".join(node.lines()[-20:])


def test_memory_writes_reach_sram_only(halted) -> None:
    node, client = halted
    flash = bytes.fromhex(ask(client, f"m{FLASH_BASE:x},10").decode())
    assert ask(client, f"M{FLASH_BASE:x},4:00000000") == b"E0d"
    assert bytes.fromhex(ask(client, f"m{FLASH_BASE:x},10").decode()) == flash
    assert ask(client, f"M{SRAM_BASE:x},4:01020304") == b"OK"
    assert ask(client, f"m{SRAM_BASE:x},4") == b"01020304"
    client.send("D")
    assert node.wait(60) == 0


def test_a_node_that_trusts_keys_offers_no_debugger(tmp_path) -> None:
    key = tmp_path / "key.pub"
    key.write_bytes(keys.public_pem(keys.generate("ed25519").public_key()))
    done = subprocess.run(
        [sys.executable, "-m", "firmware_sim", "listen", "--listen", "tcp-listen://127.0.0.1:0",
         "--trust", str(key), "--gdb", "127.0.0.1:0", "--seconds", "5"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert done.returncode == 2
    assert "--gdb: expected a node that trusts no key, got --trust too" in done.stderr
