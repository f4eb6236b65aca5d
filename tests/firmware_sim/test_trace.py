"""`firmware-sim run --trace` and `--plot`, `firmware-sim listen --trace`: every port of every
PBO after each of its jobs, with the kernel's time, in CSV and MCAP that read back the same."""

from __future__ import annotations

import csv
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest
from mcap.reader import make_reader

from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.elf import image_from_elf
from hexmigrate.links import open_link
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.sender import Sender
from pbort.ports import PortSpec
from pbort.trace.plot import PlotTrace
from pbort.trace.recorder import Sample
from tests.disk import small_disk

RUN = (
    "--native",
    "signal",
    "--set",
    "signal.amplitude=3",
    "--set",
    "gain.k=0x20000",
    "--wire",
    "signal.y=gain.x",
    "--seconds",
    "0.1",
)


def firmware_sim(
    *args: object, timeout: float = 60, disk: int | None = None
) -> subprocess.CompletedProcess[str]:
    """The command run to its end; `disk`: its files end at that many bytes (`small_disk`)."""
    command = [sys.executable, "-m", "firmware_sim", *map(str, args)]
    limit = {} if disk is None else small_disk(disk)
    return subprocess.run(
        command, capture_output=True, text=True, timeout=timeout, check=False, **limit
    )


@pytest.fixture(scope="module")
def gain(example_builds, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("trace") / "gain.hex"
    image_from_elf(example_builds["gain"].elf).write(path)
    return path


def csv_samples(path: Path) -> dict[tuple[float, str], dict[str, object]]:
    """(time, pbo) -> {port: value} from a CSV trace."""
    samples: dict[tuple[float, str], dict[str, object]] = {}
    with path.open(newline="") as stream:
        rows = csv.DictReader(stream)
        assert rows.fieldnames == ["time", "pbo", "port", "value"]
        for row in rows:
            samples.setdefault((float(row["time"]), row["pbo"]), {})[row["port"]] = json.loads(
                row["value"]
            )
    return samples


def mcap_samples(path: Path) -> tuple[dict[tuple[float, str], dict[str, object]], dict]:
    """(time, pbo) -> {port: value} from an MCAP trace, and each topic's JSON schema."""
    samples, schemas = {}, {}
    with path.open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages():
            assert channel.message_encoding == "json" and schema.encoding == "jsonschema"
            schemas[channel.topic] = json.loads(schema.data)
            values = json.loads(message.data)
            seconds = values.pop("time")
            assert message.log_time == round(seconds * 1e9)
            samples[(seconds, channel.topic.lstrip("/"))] = values
    return samples, schemas


def test_a_csv_and_an_mcap_trace_hold_the_same_samples(gain, tmp_path):
    csv_path, mcap_path, png = tmp_path / "run.csv", tmp_path / "run.mcap", tmp_path / "run.png"
    result = firmware_sim(
        "run", "--module", gain, *RUN, "--trace", csv_path, "--trace", mcap_path, "--plot", png
    )
    assert result.returncode == 0, result.stderr
    from_csv = csv_samples(csv_path)
    from_mcap, schemas = mcap_samples(mcap_path)
    assert from_csv == from_mcap
    assert len([key for key in from_csv if key[1] == "gain"]) == 10  # 100 Hz for 0.1 s
    assert sorted(schemas) == ["/gain", "/signal"]  # one channel per PBO
    assert set(schemas["/gain"]["properties"]) == {"time", "x", "k", "y"}
    for (_, pbo), values in from_csv.items():
        if pbo == "gain":
            assert values["y"] == 2 * values["x"]  # k = 2.0 in Q16.16
    ramp = [values["y"] for (_, pbo), values in sorted(from_csv.items()) if pbo == "signal"]
    assert ramp == [3 * n for n in range(1, 11)]


def test_the_plot_draws_the_ports(gain, tmp_path):
    png = tmp_path / "run.png"
    assert firmware_sim("run", "--module", gain, *RUN, "--plot", png).returncode == 0
    pixels = matplotlib.image.imread(png)[:, :, :3].reshape(-1, 3)
    colours = np.unique((pixels * 255).astype(int), axis=0)
    assert len(colours) > 20  # lines, legends and grid, not a blank canvas


def drawn(chosen: tuple[str, ...] = ()) -> dict[str, set[str]]:
    """The ports a PlotTrace keeps of gain's and signal's samples, by PBO."""
    plot = PlotTrace(chosen)
    specs = {
        "gain": (PortSpec.input("x"), PortSpec.output("y"), PortSpec.const("k")),
        "signal": (PortSpec.output("y"), PortSpec.const("amplitude")),
    }
    plot.write(Sample(0.01, "gain", {"x": 3, "y": 6, "k": 131072}), specs["gain"])
    plot.write(Sample(0.01, "signal", {"y": 3, "amplitude": 3}), specs["signal"])
    return {pbo: set(series) for pbo, series in plot._series.items() if series}


def test_a_plot_draws_signals_not_constants_unless_ports_are_named() -> None:
    # gain.k = 131072 (2.0 in Q16.16) on gain's axis would flatten x and y (issue 26, point 10)
    assert drawn() == {"gain": {"x", "y"}, "signal": {"y"}}
    assert drawn(("gain.k", "signal.y")) == {"gain": {"k"}, "signal": {"y"}}


def test_plot_ports_without_a_plot_is_a_usage_error(gain, tmp_path):
    result = firmware_sim("run", "--module", gain, *RUN, "--plot-port", "gain.y")
    assert result.returncode == 2
    assert "--plot-port goes with --plot FILE.png" in result.stderr


@pytest.mark.parametrize(
    ("option", "message"),
    [
        (("--trace", "run.txt"), "expected a file name ending in .csv or .mcap, got .txt"),
        (("--plot", "run.jpg"), "expected a file name ending in .png"),
    ],
)
def test_a_trace_name_of_no_known_format_is_a_usage_error(gain, tmp_path, option, message):
    flag, name = option
    result = firmware_sim("run", "--module", gain, *RUN, flag, tmp_path / name)
    assert result.returncode == 2
    assert message in result.stderr
    assert not (tmp_path / name).exists()


def ramp_running(url: str, timeout: float = 20.0) -> None:
    """Wait until the node at `url` reads back a signal.y above 0: the ramp has run a cycle."""
    deadline = time.monotonic() + timeout
    with open_link(url) as link:
        control = NodeControl(Sender(link))
        while (value := control.read(("signal.y",))[0][1]) == 0:
            assert time.monotonic() < deadline, f"signal.y still {value} after {timeout:g} s"
            time.sleep(0.05)


def test_a_listening_node_stopped_by_sigterm_leaves_whole_traces(tmp_path):
    csv_path, mcap_path = tmp_path / "node.csv", tmp_path / "node.mcap"
    options = ("--native", "signal", "--set", "signal.amplitude=2")
    traces = ("--trace", str(csv_path), "--trace", str(mcap_path))
    with NodeProcess("tcp-listen://127.0.0.1:0", *options, *traces) as node:
        ramp_running(node.url)  # listening, and the signal running on the real-time clock
        node.child.process.send_signal(signal.SIGTERM)
        status = node.child.wait(timeout=20)
    assert "stopped" in node.lines()
    assert status == 0, node.lines()
    from_csv = csv_samples(csv_path)
    from_mcap, _ = mcap_samples(mcap_path)
    assert from_csv == from_mcap and from_csv
    ramp = [values["y"] for (_, pbo), values in sorted(from_csv.items()) if pbo == "signal"]
    assert ramp == [2 * n for n in range(1, len(ramp) + 1)]


@pytest.mark.parametrize("suffix", [".csv", ".mcap"])
def test_a_trace_the_disk_refuses_ends_a_run_naming_it(gain, tmp_path, suffix):
    trace = tmp_path / f"run{suffix}"
    result = firmware_sim(
        "run", "--native", "signal", "--trace", trace, "--seconds", 60, disk=20000
    )
    assert result.returncode == 1
    assert result.stderr == f"error: trace {trace}: cannot write it: File too large\n"


def test_a_plot_the_disk_refuses_ends_a_run_naming_it_and_is_not_left_cut(gain, tmp_path):
    plot = tmp_path / "run.png"
    result = firmware_sim("run", "--module", gain, *RUN, "--plot", plot, disk=4000)  # 40 kB
    assert result.returncode == 1
    assert result.stderr == f"error: trace {plot}: cannot write it: File too large\n"
    assert list(tmp_path.iterdir()) == []


def test_a_listening_node_whose_trace_the_disk_refuses_says_so_and_runs_on(tmp_path):
    trace = tmp_path / "node.csv"
    options = ("--native", "signal", "--set", "signal.amplitude=2", "--default-rate", 1000)
    result = firmware_sim(
        "listen",
        "--listen",
        "tcp-listen://127.0.0.1:0",
        *options,
        "--show",
        "signal.y",
        "--trace",
        trace,
        "--seconds",
        3.5,
        disk=12000,
    )
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    lost = (
        f"trace {trace}: cannot write it: File too large; the trace stops there, the node runs on"
    )
    assert lost in lines
    shown = [
        int(line.rpartition("=")[2]) for line in lines[lines.index(lost) :] if "signal.y=" in line
    ]
    assert len(shown) >= 2 and shown == sorted(shown) and shown[0] > 0  # the ramp ran on
