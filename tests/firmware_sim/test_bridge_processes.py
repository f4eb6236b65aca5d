"""Ports between node processes, as a user wires them: two ``firmware-sim listen`` nodes over TCP
on 127.0.0.1, node A with the native signal, node B with gain sent to it; the host imports on B,
exports on A with NodeControl, starts both and reads gain.y on B. In real time gain.y comes
alive; in lock-step time, driven by a TimeMaster, two runs give the same values after every
quantum, and every node's clock is the master's."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

import pytest

from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.elf import image_from_elf
from hexmigrate.links import open_link
from hexmigrate.transfer.control import Number
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.sender import Sender
from hexmigrate.transfer.time_master import TimeMaster
from tests.firmware_sim.host_side import hexmigrate

LISTEN = "tcp-listen://127.0.0.1:0"
READS = 100
"""Reads of gain.y at most, a tenth of a second apart, before a real-time test gives up."""
QUANTUM = 0.01


@pytest.fixture(scope="module")
def gain_hex(example_builds, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("bridge") / "gain.hex"
    image_from_elf(example_builds["gain"].elf).write(path)
    return path


@contextmanager
def two_nodes(gain_hex: Path, *options: str) -> Iterator[tuple[NodeControl, NodeControl]]:
    """Node A (signal, amplitude 3) and node B (gain, k = 2), both off, bridge 1 from signal.y
    to gain.x, and their controls."""
    with ExitStack() as stack:
        a = stack.enter_context(
            NodeProcess(
                LISTEN, "--native", "signal", "--set", "signal.amplitude=3", "--no-start", *options
            )
        )
        b = stack.enter_context(NodeProcess(LISTEN, "--no-start", *options))
        hexmigrate("send", gain_hex, "--to", b.url, "--quiet")
        b.wait_for(r"^registered gain at ")
        controls = []
        for node in (a, b):
            link = stack.enter_context(open_link(node.url))
            controls.append(NodeControl(Sender(link, "binary")))
        on_a, on_b = controls
        on_b.set("gain.k=0x20000")
        url = on_b.import_port(1, "gain.x", LISTEN)
        said = on_a.export_port(1, "signal.y", url)
        assert said == f"exported signal.y as bridge 1 to {url.partition('#')[0]}"
        yield on_a, on_b


def test_a_port_crosses_from_one_node_process_to_another(gain_hex: Path) -> None:
    with two_nodes(gain_hex) as (on_a, on_b):
        on_a.start("signal")
        on_b.start("gain")
        for _ in range(READS):
            (gain,) = on_b.read(("gain.y",))
            if gain[1] != 0:
                break
            time.sleep(0.1)
        assert gain[1] != 0


def lock_step_run(gain_hex: Path, quanta: int) -> list[tuple[tuple[str, Number], ...]]:
    """The values of gain.x and gain.y on B after each quantum of a lock-step run."""
    with two_nodes(gain_hex, "--lock-step") as (on_a, on_b):
        on_a.start("signal")
        on_b.start("gain")
        master = TimeMaster({"a": on_a, "b": on_b}, QUANTUM)
        master.route(1, "a", "b")
        series = []
        for k in range(1, quanta + 1):
            master.run_until(k * QUANTUM)
            assert (
                master.clocks == {"a": master.now, "b": master.now} == dict.fromkeys("ab", k / 100)
            )
            series.append(on_b.read(("gain.x", "gain.y")))
        assert master.counts == {1: quanta}  # signal and its exporter at 100 Hz
    return series


def test_a_lock_step_run_across_processes_is_reproducible(gain_hex: Path) -> None:
    first = lock_step_run(gain_hex, 20)
    assert first == lock_step_run(gain_hex, 20)
    assert any(value != 0 for _, value in (values[1] for values in first))
