"""Node control figures against real listening nodes (``firmware-sim listen`` processes), each
against a baseline of the same run:

- control round trip: `NodeControl.read` of one port, and `start` / `stop` of a PBO, against the
  bare request/echo over the same link (a `Ping` answered by a `Pong` through the same
  `Sender`), over TCP (``socket://`` to a node on ``tcp-listen://``) and over a pty pair. Goal:
  a control request within 2x the echo (median of the round trips, taken in turn so that both
  see the same machine load). Also over TCP to a node that trusts a key (``--trust``), on a
  connection authenticated with it: the requests cost what they cost on an open node, and a
  new authentication (CHALLENGE + AUTH, one signature each way) is timed against the echo;
- report throughput: NODES node processes (each on its own loopback address, 127.0.0.2 on), each
  running the native signal into the compiled `gain` example (an E-PBO, so each report carries
  its evaluator's outputs as the Decider reads them), each push a report every 100 ms with two
  ports' values (`NodeControl.watch`) to this process, which reads them all
  (`NodeControl.pushes`, a thread per node); the figure is this process's CPU share
  (`time.process_time` over wall time) against the same links open with nothing pushed. Goal:
  under 10% of one core. It prints the reports and bytes per second each node sends (the
  framed bytes on the wire, reports and heartbeats);
- the paper scenario across processes: ``python -m visual_servoing run --scenario paper
  --processes`` (lock-step time: the two nodes and the servo emulator started, run and stopped,
  the manager in the command's process) against the in-process ``run --scenario paper``, each
  timed whole on the wall clock as a user runs it. Goal: at most 2x the in-process run.

    python benchmarks/control.py [--requests N] [--nodes N] [--seconds S] [--scenario NAME]
                                 [--repeats N]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from nodes import node_process

from commandline.arguments import integer, real
from hexmigrate.elf import image_from_elf
from hexmigrate.image import ModuleImage
from hexmigrate.links import open_link
from hexmigrate.links.base import LinkBase
from hexmigrate.links.framing import frame
from hexmigrate.signing import keys
from hexmigrate.transfer.control_client import NodeControl
from hexmigrate.transfer.messages import Heartbeat, PerformanceReport, encode
from hexmigrate.transfer.sender import Sender
from module_sdk.build import EXAMPLES_DIR, build_module

if TYPE_CHECKING:
    from hexmigrate.signing.keys import PrivateKey

ROUND_TRIP_GOAL = 2.0  # a control request's median round trip / the echo's
UNGOALED = ("echo", "authenticate")  # the baseline, and a figure with no goal
CPU_GOAL = 0.10  # of one core, for NODES nodes at REPORT_HZ reports/s each
PROCESSES_GOAL = 2.0  # the scenario's run across processes / in process
SCENARIO_TIMEOUT = 900.0
REPORT_PERIOD_MS = 100
NODE_OPTIONS = ("--native", "signal", "--set", "signal.amplitude=3")
REPORTING = (*NODE_OPTIONS, "--set", "gain.k=0x20000", "--wire", "signal.y=gain.x")
"""A reporting node: the signal feeds the gain it is sent, which starts once installed."""
WATCHED = ("signal.y", "gain.y")


# The nodes.


def gain_image() -> ModuleImage:
    """The `gain` example compiled (an E-PBO: its evaluator reports F0 and N0)."""
    with tempfile.TemporaryDirectory() as folder:
        return image_from_elf(build_module(EXAMPLES_DIR / "gain.c", Path(folder)).elf)


def controlled(stack: ExitStack, url: str) -> NodeControl:
    """A NodeControl over a link to `url` that `stack` closes."""
    link: LinkBase = stack.enter_context(open_link(url))
    return NodeControl(Sender(link))


# Round trips.


def round_trips(
    control: NodeControl, requests: int, key: PrivateKey | None = None
) -> dict[str, list[float]]:
    """Seconds of each round trip, per kind, taken in turn: echo, read, start, stop, and with a
    `key` (the node trusts it) an authentication of the connection."""
    toggles = (("start", control.start), ("stop", control.stop))
    kinds: list[tuple[str, Callable[[], object]]] = [
        ("echo (Ping/Pong)", control.sender.ping),
        ("read 1 port", lambda: control.read(("signal.y",))),
        *((name, lambda request=request: request("signal")) for name, request in toggles),
    ]
    if key is not None:
        control.sender.authenticate(key)
        kinds.append(("authenticate", lambda: control.sender.authenticate(key)))
    times: dict[str, list[float]] = {name: [] for name, _ in kinds}
    for _, request in kinds:  # warm up: imports, the node's first answers
        request()
    for _ in range(requests):
        for name, request in kinds:
            start = time.perf_counter()
            request()
            times[name].append(time.perf_counter() - start)
    return times


def print_round_trips(wire: str, times: dict[str, list[float]]) -> bool:
    """One line per kind; True if every control request met the goal."""
    echo = statistics.median(times["echo (Ping/Pong)"])
    met = True
    for name, samples in times.items():
        median = statistics.median(samples)
        ratio = median / echo
        ninetieth = statistics.quantiles(samples, n=10)[-1]
        goal = "baseline" if name.startswith("echo") else f"{ROUND_TRIP_GOAL:g}x"
        goal = "-" if name == "authenticate" else goal
        ok = "" if name.startswith(UNGOALED) else ("yes" if ratio <= ROUND_TRIP_GOAL else "NO")
        met = met and ok != "NO"
        print(
            f"{wire:7}{name:18}{median * 1e6:>10.0f}{ninetieth * 1e6:>10.0f}{ratio:>8.2f}"
            f"{goal:>10}{ok:>5}"
        )
    return met


# Reports.


@dataclass
class Tally:
    """What one node pushed, counted by the thread that reads it."""

    reports: int = 0
    heartbeats: int = 0
    wire_bytes: int = 0
    lock: threading.Lock = field(default_factory=threading.Lock)

    def add(self, message: PerformanceReport | Heartbeat) -> None:
        with self.lock:
            if isinstance(message, PerformanceReport):
                self.reports += 1
            else:
                self.heartbeats += 1
            self.wire_bytes += len(frame(encode(message, text=False)))

    def snapshot(self) -> tuple[int, int, int]:
        with self.lock:
            return self.reports, self.heartbeats, self.wire_bytes


def read_pushes(control: NodeControl, seconds: float, tally: Tally) -> None:
    for message in control.pushes(seconds):
        tally.add(message)


def cpu_share(seconds: float) -> float:
    """This process's CPU time over wall time while the main thread sleeps `seconds`."""
    cpu, wall = time.process_time(), time.perf_counter()
    time.sleep(seconds)
    return (time.process_time() - cpu) / (time.perf_counter() - wall)


def report_throughput(nodes: int, seconds: float) -> bool:
    """Start `nodes` nodes, measure this process idle with their links open, then reading
    their reports; print the figures; True if the goal is met."""
    warm_up = 1.0
    image = gain_image()
    with ExitStack() as stack:
        urls = [
            stack.enter_context(node_process(f"tcp-listen://127.0.0.{2 + index}:0", *REPORTING))
            for index in range(nodes)
        ]
        controls = [controlled(stack, url) for url in urls]
        for control in controls:
            control.sender.send(image)
        idle = cpu_share(seconds)
        tallies = [Tally() for _ in controls]
        readers = [
            threading.Thread(target=read_pushes, args=(control, warm_up + seconds + 1.0, tally))
            for control, tally in zip(controls, tallies, strict=True)
        ]
        for control in controls:
            control.watch(REPORT_PERIOD_MS, WATCHED)
        for reader in readers:
            reader.start()
        time.sleep(warm_up)
        before = [tally.snapshot() for tally in tallies]
        wall = time.perf_counter()
        busy = cpu_share(seconds)
        after = [tally.snapshot() for tally in tallies]
        wall = time.perf_counter() - wall
        for reader in readers:
            reader.join()
        for control in controls:
            control.watch(0)
    print_reports(nodes, idle, busy, wall, before, after)
    return busy < CPU_GOAL


def print_reports(
    nodes: int,
    idle: float,
    busy: float,
    wall: float,
    before: list[tuple[int, int, int]],
    after: list[tuple[int, int, int]],
) -> None:
    rates = [
        [(late - early) / wall for early, late in zip(start, end, strict=True)]
        for start, end in zip(before, after, strict=True)
    ]
    reports = sum(rate[0] for rate in rates)
    per_node = [rate[2] for rate in rates]
    print(
        f"{nodes} nodes on 127.0.0.2..127.0.0.{1 + nodes}, each a report every "
        f"{REPORT_PERIOD_MS} ms (gain's F0 and N0, leftover power, {' and '.join(WATCHED)})"
    )
    print(f"  reports read         {reports:8.1f}/s ({reports / nodes:.1f}/s per node)")
    print(
        f"  bytes per node       {statistics.mean(per_node):8.0f} B/s "
        f"(min {min(per_node):.0f}, max {max(per_node):.0f}; reports and heartbeats, framed)"
    )
    print(f"  host CPU, links open, nothing pushed (baseline)  {100 * idle:6.2f}% of one core")
    print(
        f"  host CPU, reading every report                   {100 * busy:6.2f}% of one core"
        f"  (goal < {100 * CPU_GOAL:g}%: {'yes' if busy < CPU_GOAL else 'NO'}; "
        f"{busy / idle if idle else float('inf'):.1f}x the baseline)"
    )


def scenario_run_time(scenario: str, repeats: int) -> bool:
    """Time the scenario in process, then across processes in lock-step time, `repeats` times
    in turn (both see the same machine load); print the medians."""
    times: dict[str, list[float]] = {"in process": [], "across processes": []}
    with tempfile.TemporaryDirectory(prefix="scenario-") as folder:
        for run in range(repeats):
            for label, extra in (("in process", ()), ("across processes", ("--processes",))):
                out = Path(folder) / f"{label.replace(' ', '-')}-{run}"
                command = [sys.executable, "-m", "visual_servoing", "run", "--scenario", scenario]
                command += ["--out", str(out), "--json", *extra]
                start = time.perf_counter()
                subprocess.run(command, check=True, capture_output=True, timeout=SCENARIO_TIMEOUT)
                times[label].append(time.perf_counter() - start)
    here = statistics.median(times["in process"])
    across = statistics.median(times["across processes"])
    ratio = across / here
    met = ratio <= PROCESSES_GOAL
    print(
        f"the {scenario} scenario, run whole from the command line (wall clock, median of "
        f"{repeats})"
    )
    print(f"  in process (baseline)              {here:6.1f} s")
    print(
        f"  across processes, lock-step time   {across:6.1f} s"
        f"  ({ratio:.2f}x; goal <= {PROCESSES_GOAL:g}x: {'yes' if met else 'NO'})"
    )
    return met


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--requests", type=integer(2, 100_000), default=200, help="round trips of each kind"
    )
    parser.add_argument("--nodes", type=integer(1, 200), default=10, help="nodes that push reports")
    parser.add_argument(
        "--seconds",
        type=real(above=0, maximum=3600, unit="s"),
        default=5.0,
        help="length of each CPU window",
    )
    parser.add_argument("--scenario", default="paper", help="the scenario run across processes")
    parser.add_argument(
        "--repeats",
        type=integer(1, 100),
        default=3,
        help="runs of the scenario each way (the median counts)",
    )
    args = parser.parse_args()

    print(f"control round trip, {args.requests} of each kind taken in turn (microseconds)")
    print(f"{'link':7}{'request':18}{'median':>10}{'p90':>10}{'ratio':>8}{'goal':>10}{'met':>5}")
    met = True
    for wire, listen in (("TCP", "tcp-listen://127.0.0.1:0"), ("pty", "pty")):
        with node_process(listen, *NODE_OPTIONS, "--no-start") as url, ExitStack() as stack:
            met = (
                print_round_trips(wire, round_trips(controlled(stack, url), args.requests)) and met
            )
    key = keys.generate("ed25519")
    with tempfile.TemporaryDirectory() as folder:
        public = Path(folder) / "trusted.pub.pem"
        public.write_bytes(keys.public_pem(key.public_key()))
        trusting = (*NODE_OPTIONS, "--no-start", "--trust", str(public))
        with node_process("tcp-listen://127.0.0.1:0", *trusting) as url, ExitStack() as stack:
            times = round_trips(controlled(stack, url), args.requests, key)
            met = print_round_trips("TCP+key", times) and met
    print()
    met = report_throughput(args.nodes, args.seconds) and met
    print()
    met = scenario_run_time(args.scenario, args.repeats) and met
    if not met:
        print("a goal was missed")


if __name__ == "__main__":
    main()
