"""ReFrESH over a fleet of node processes: what detecting, deciding, repairing and listening cost
as the fleet grows from 10 to 50 nodes (the model beyond: docs/fleet.md).

For each size N, N ``firmware-sim listen`` processes run on this machine, node i on 127.0.0.(2+i),
each with --per-node (2) small native E-PBOs of `fleet_natives` (a four-stage pipeline task whose
alternatives are dealt round the robots, `fleet_task`). The manager runs in this process: a
`Runtime` over a `LinkApplier`, estimating in shadow runs on a host kernel, every node watched
at a report every PERIOD s (10 reports/s per node, plus a heartbeat every second). Every PERIOD
the manager files every node's pushes (as a loss detector must) and steps the runtime. Measured:

- steady state, over a window of --seconds: the manager's CPU share (`time.process_time` over
  wall time), the node processes' CPU (from /proc), and the bytes per second per node the nodes
  push (reports and heartbeats, framed, counted on each link); the bytes per second per node the
  manager sends (control requests) are counted over the whole managed run (deploy and repair);
- a fault: the running sensor's `fault` constant is set over its link (a node takes constants
  only while a PBO is off: STOP, SET, START), and its estimator is told so (the host's live
  input): the time from the START to the Decider's detection (the runtime's debounce of 5 looks,
  0.5 s, is most of it), the decision (locate + synthesize + choose, with estimation in shadow
  runs: the runtime's own timing of `decide`; then the same decision again once the nodes are
  stopped, "quiet", and the shadow runs it made) and the time to apply the plan (from the
  decision's choice to the new configuration running: the old bridge down, a stop, a start with
  rate and constants, a bridge between two nodes);
- a killed node: one node the task does not use is SIGKILLed; the time until the manager's
  own loss detection (`LinkApplier.lost`, what the runtime asks every look) declares it lost
  with `lost_after` = SILENCE report periods, asked every PERIOD / 10.

Then the exponent b of a power law y = a n^b fitted (least squares on the logs) to each figure
over the sizes, and the goals at the largest size: a killed node lost within 0.5 s, a decision
under 50 ms, the manager under 50% of one core.

    python benchmarks/fleet.py [--sizes 10,25,50] [--seconds S] [--per-node M]
    python benchmarks/fleet.py --sizes 6,10 --seconds 2      # a quick check, about a minute
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import statistics
import time
from collections.abc import Callable, Mapping, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, fields
from pathlib import Path

from fleet_natives import STAGES, module_name
from fleet_task import Fleet, fleet
from nodes import node_processes

from firmware_sim.core.natives import load_natives
from firmware_sim.core.node import Node
from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.links import open_link
from hexmigrate.links.base import Link, LinkBase
from hexmigrate.links.framing import frame
from refresh.adaptation import decide
from refresh.appliers.over_links import LinkApplier
from refresh.configuration import Configuration
from refresh.estimators.host import host_estimators
from refresh.events import EventLog
from refresh.remote.remote_node import RemoteNode
from refresh.runtime import Runtime, RuntimeSettings

HERE = Path(__file__).parent
SIZES = (10, 25, 50)
PERIOD = 0.1
"""Seconds between two reports of a node, and between two looks of the Decider."""
SILENCE = 2
"""Report periods without a word from a node after which the manager declares it lost."""
WARM_UP = 1.0
REPAIR_TIMEOUT = 10.0
QUIET_REPEATS = 5
LOST_GOAL = 0.5  # s, a killed node declared lost
DECISION_GOAL = 0.050  # s, locate + synthesize + choose
CPU_GOAL = 0.50  # of one core, the manager at 10 reports/s per node


class CountingLink(LinkBase):
    """A link that counts the framed bytes it sends and receives, around another link."""

    def __init__(self, inner: Link) -> None:
        super().__init__(inner.url)
        self.inner = inner
        self.sent = 0
        self.received = 0

    def _send(self, message: bytes) -> None:
        self.inner.send(message)
        self.sent += len(frame(message))

    def _receive(self, timeout: float) -> bytes | None:
        message = self.inner.receive(timeout)
        if message is not None:
            self.received += len(frame(message))
        return message

    def _close(self) -> None:
        self.inner.close()


@dataclass
class Row:
    """The figures of one size."""

    nodes: int
    detect: float
    """Seconds from the faulty sensor's START to the Decider's detection."""
    decide: float
    """Seconds of locate + synthesize + choose, while the nodes run."""
    quiet: float
    """Seconds of the same decision once the nodes are stopped."""
    estimates: int
    """Shadow runs the decision made (Base Choice test cases and candidates)."""
    apply: float
    """Seconds from the choice to the new configuration running."""
    control: float
    """Bytes per second per node the manager sends, over the whole managed run."""
    reports: float
    """Bytes per second per node the nodes push, in the steady window."""
    manager: float
    """The manager's CPU share of one core, in the steady window."""
    node_cpu: float
    """One node process's mean CPU share of one core, in the steady window."""
    lost: float
    """Seconds from a node's SIGKILL to the manager declaring it lost (its link closes)."""
    silent: float
    """Seconds from a node's SIGSTOP (a node that hangs or loses power: nothing closes) to the
    manager declaring it lost, after SILENCE report periods of silence."""


COLUMNS = {
    "detect": ("detect s", 1.0, "{:.3f}"),
    "decide": ("decide ms", 1e3, "{:.2f}"),
    "quiet": ("quiet ms", 1e3, "{:.2f}"),
    "estimates": ("estimates", 1, "{:.0f}"),
    "apply": ("apply ms", 1e3, "{:.1f}"),
    "control": ("control B/s", 1.0, "{:.1f}"),
    "reports": ("report B/s", 1.0, "{:.0f}"),
    "manager": ("manager %", 100.0, "{:.1f}"),
    "node_cpu": ("node %", 100.0, "{:.2f}"),
    "lost": ("lost s", 1.0, "{:.3f}"),
    "silent": ("silent s", 1.0, "{:.3f}"),
}


# The fleet's processes and links.


def node_options(natives: Sequence[str], robot: str) -> list[str]:
    """What `robot`'s node runs: its natives, all off until the manager starts them."""
    chosen = [word for name in natives for word in ("--native", name)]
    return ["--name", robot, "--natives", "fleet_natives", *chosen, "--no-start"]


def start_nodes(stack: ExitStack, task: Fleet) -> dict[str, NodeProcess]:
    """A node process per robot, robot i on 127.0.0.(2+i); `stack` stops them."""
    robots = list(task.natives)
    if len(robots) > 253:
        raise SystemExit(f"expected at most 253 nodes (127.0.0.2..254), got {len(robots)}")
    listens = [
        (f"tcp-listen://127.0.0.{2 + index}:0", node_options(task.natives[robot], robot))
        for index, robot in enumerate(robots)
    ]
    return dict(zip(robots, node_processes(stack, listens, cwd=HERE), strict=True))


def open_applier(
    stack: ExitStack, processes: Mapping[str, NodeProcess]
) -> tuple[LinkApplier, dict[str, CountingLink]]:
    """The manager's applier over a counted link to each node, each watched every PERIOD."""
    links: dict[str, CountingLink] = {}
    nodes: dict[str, RemoteNode] = {}
    for robot, process in processes.items():
        link = links[robot] = CountingLink(stack.enter_context(open_link(process.url)))
        nodes[robot] = stack.enter_context(RemoteNode(robot, link, period=PERIOD))
    return stack.enter_context(LinkApplier(nodes)), links


# The manager's loop.


class Manager:
    """The runtime driven on the wall clock: every PERIOD, every node's pushes filed, then a
    step of the runtime. A tick that comes late (after a repair) is not made up for with a
    burst of ticks: the next one is a PERIOD later."""

    def __init__(self, runtime: Runtime, applier: LinkApplier, start: float) -> None:
        self.runtime = runtime
        self.applier = applier
        self.next = start

    def run(self, seconds: float, until: Callable[[], bool] = lambda: False) -> bool:
        """Tick for `seconds`, or until `until()` holds after a tick (then True)."""
        end = time.perf_counter() + seconds
        while time.perf_counter() < end:
            time.sleep(max(0.0, self.next - time.perf_counter()))
            self.next = max(self.next, time.perf_counter()) + PERIOD
            for node in self.applier.nodes.values():
                node.poll()
            self.runtime.step()
            if until():
                return True
        return False


def steady(
    manager: Manager,
    seconds: float,
    links: Mapping[str, CountingLink],
    processes: Mapping[str, NodeProcess],
) -> tuple[float, float, float]:
    """Over `seconds` of the manager's loop: its CPU share, one node's mean CPU share, and the
    bytes per second per node the nodes pushed."""
    cpu, wall = time.process_time(), time.perf_counter()
    received = sum(link.received for link in links.values())
    nodes_cpu = sum(process.cpu_seconds() for process in processes.values())
    manager.run(seconds)
    wall = time.perf_counter() - wall
    share = (time.process_time() - cpu) / wall
    nodes_cpu = sum(process.cpu_seconds() for process in processes.values()) - nodes_cpu
    pushed = sum(link.received for link in links.values()) - received
    count = len(processes)
    return share, nodes_cpu / wall / count, pushed / wall / count


# The fault and the killed node.


@dataclass(frozen=True)
class Repair:
    """What the repair of the fault took: detection, decision and apply seconds, the estimates
    (shadow runs) the decision made, and what it decided from (for `quiet_decision`)."""

    detect: float
    decide: float
    apply: float
    estimates: int
    current: Configuration
    detected_at: float


def repair(manager: Manager, applier: LinkApplier, faults: dict[str, object]) -> Repair:
    """Break the running sensor and let the runtime repair it."""
    runtime = manager.runtime
    switches: list[float] = []
    runtime.on_switch = lambda _configuration: switches.append(runtime.clock())
    current = runtime.current
    assert current is not None
    sensor = current.instances[0]
    node = applier.node(current.robot_of(sensor))
    for what, request in (
        ("STOP", lambda: node.control.stop(sensor)),
        ("SET", lambda: node.control.set(f"{sensor}.fault=1")),
        ("START", lambda: node.control.start(sensor)),
    ):
        node.ask(f"{what} {sensor} (the fault)", request)
    fault_at = runtime.clock()
    faults[f"{sensor}.fault"] = 1
    if not manager.run(REPAIR_TIMEOUT, lambda: bool(switches)):
        raise SystemExit(f"no repair within {REPAIR_TIMEOUT:g} s of the fault on {sensor}")
    log = runtime.log
    record = runtime.history.reconfigurations[-1]
    return Repair(
        detect=log.of_kind("detection")[-1].time - fault_at,
        decide=record.decision_seconds,
        apply=switches[-1] - log.of_kind("choice")[-1].time,
        estimates=len(log.of_kind("test_case")) + len(log.of_kind("candidate")),
        current=current,
        detected_at=record.detected_at,
    )


def quiet_decision(task: Fleet, faults: Mapping[str, object], repaired: Repair) -> float:
    """The same decision again once the nodes are stopped (median of QUIET_REPEATS seconds): what
    it costs without fifty node processes taking the same two cores."""
    natives = load_natives(["fleet_natives"])
    times = []
    with Node("manager") as host:
        estimators = host_estimators(task.database, task.task, host, natives, lambda: faults)
        for _ in range(QUIET_REPEATS):
            estimator = estimators(repaired.detected_at, RuntimeSettings().estimate_steps)
            start = time.perf_counter()
            decide(repaired.current, task.database, task.task, estimator, EventLog())
            times.append(time.perf_counter() - start)
    return statistics.median(times)


def time_to_lost(applier: LinkApplier, robot: str, kill: Callable[[], None]) -> float:
    """Seconds from `kill()` until the manager's loss detection (`LinkApplier.lost`, with
    SILENCE report periods of silence allowed, the runtime's `lost_after`) declares `robot`'s
    node lost, asked every PERIOD / 10 as the runtime's looks would."""
    after = SILENCE * PERIOD
    assert robot not in applier.lost(after), f"{robot} counts as lost before the kill"
    kill()
    killed_at = time.perf_counter()
    while robot not in applier.lost(after):
        time.sleep(PERIOD / 10)
    return time.perf_counter() - killed_at


def spares(runtime: Runtime, processes: Mapping[str, NodeProcess]) -> tuple[str, str]:
    """Two robots the running configuration does not use (the last two): one to kill, one to
    stop."""
    assert runtime.current is not None
    used = {placement.robot for placement in runtime.current.placements}
    spare = [robot for robot in processes if robot not in used]
    if len(spare) < 2:
        raise SystemExit(f"expected two robots the task does not use, got {len(spare)}")
    return spare[-1], spare[-2]


def signal_to(node: NodeProcess, number: signal.Signals) -> Callable[[], None]:
    """A call that sends `number` to `node`'s process."""
    return lambda: os.kill(node.pid, number)


# One size.


def measure(size: int, seconds: float, per_node: int) -> Row:
    """Start `size` nodes, manage the task over them and take the figures."""
    task = fleet(size, per_node)
    natives = load_natives(["fleet_natives"])
    faults: dict[str, object] = {}
    with ExitStack() as stack:
        processes = start_nodes(stack, task)
        start = time.perf_counter()
        applier, links = open_applier(stack, processes)
        host = stack.enter_context(Node("manager"))
        estimators = host_estimators(
            task.database, task.task, host, natives, inputs=lambda: dict(faults)
        )
        settings = RuntimeSettings(decision_period=PERIOD)
        runtime = Runtime(
            task.database,
            task.task,
            applier,
            estimators,
            lambda: time.perf_counter() - start,
            settings,
        )
        runtime.deploy()
        manager = Manager(runtime, applier, time.perf_counter())
        manager.run(WARM_UP)
        share, node_share, pushed = steady(manager, seconds, links, processes)
        repaired = repair(manager, applier, faults)
        control = sum(link.sent for link in links.values())
        control /= (time.perf_counter() - start) * size
        killed, stopped = spares(runtime, processes)
        lost = time_to_lost(applier, killed, signal_to(processes[killed], signal.SIGKILL))
        silent = time_to_lost(applier, stopped, signal_to(processes[stopped], signal.SIGSTOP))
        os.kill(processes[stopped].pid, signal.SIGCONT)
    quiet = quiet_decision(task, faults, repaired)
    return Row(
        size,
        repaired.detect,
        repaired.decide,
        quiet,
        repaired.estimates,
        repaired.apply,
        control,
        pushed,
        share,
        node_share,
        lost,
        silent,
    )


# The report.


def exponent(sizes: Sequence[int], values: Sequence[float]) -> float:
    """b of log y = a + b log n, least squares over the sizes (nan for a value <= 0)."""
    if any(value <= 0 for value in values) or len(sizes) < 2:
        return math.nan
    xs = [math.log(size) for size in sizes]
    ys = [math.log(value) for value in values]
    mean_x, mean_y = sum(xs) / len(xs), sum(ys) / len(ys)
    spread = sum((x - mean_x) ** 2 for x in xs)
    return sum((x - mean_x) * (y - mean_y) for x, y in zip(xs, ys, strict=True)) / spread


def print_table(rows: Sequence[Row]) -> None:
    """One line per size, then the fitted exponents."""
    names = [field.name for field in fields(Row)][1:]
    widths = [len(COLUMNS[name][0]) + 2 for name in names]
    headers = [f"{COLUMNS[name][0]:>{width}}" for name, width in zip(names, widths, strict=True)]
    print(f"{'nodes':>5}" + "".join(headers))
    for row in rows:
        cells = []
        for name, width in zip(names, widths, strict=True):
            _, scale, form = COLUMNS[name]
            cells.append(f"{form.format(getattr(row, name) * scale):>{width}}")
        print(f"{row.nodes:>5}" + "".join(cells))
    sizes = [row.nodes for row in rows]
    if len(sizes) < 2:
        return
    slopes = [exponent(sizes, [getattr(row, name) for row in rows]) for name in names]
    print(f"{'b':>5}" + "".join(f"{s:>{w}.2f}" for s, w in zip(slopes, widths, strict=True)))
    print(f"(b: the exponent of y = a n^b fitted over {', '.join(map(str, sizes))} nodes)")


def print_goals(row: Row) -> bool:
    """Each goal at the largest size measured; True if all are met."""
    goals = (
        (f"a killed node lost within {LOST_GOAL:g} s", row.lost, LOST_GOAL, 1.0, "s"),
        (f"a decision under {DECISION_GOAL * 1e3:g} ms", row.decide, DECISION_GOAL, 1e3, "ms"),
        (f"the manager under {CPU_GOAL:.0%} of one core", row.manager, CPU_GOAL, 100, "%"),
    )
    print(f"goals at {row.nodes} nodes (set for 50):")
    met = True
    for text, value, goal, scale, unit in goals:
        ok = value < goal
        met = met and ok
        print(f"  {text:38} {value * scale:8.3f} {unit:2}  {'met' if ok else 'NOT met'}")
    print(f"  (the same decision with the nodes stopped: {row.quiet * 1e3:.3f} ms)")
    return met


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--sizes",
        type=lambda text: tuple(int(size) for size in text.split(",")),
        default=SIZES,
        help="node counts, comma-separated (default 10,25,50)",
    )
    parser.add_argument("--seconds", type=float, default=5.0, help="the steady window (s)")
    parser.add_argument("--per-node", type=int, default=2, help="modules per node (default 2)")
    args = parser.parse_args()
    # a robot per stage, one the repair moves a stage to, and two spares (one killed, one stopped)
    fewest = len(STAGES) + 2
    if min(args.sizes) < fewest:
        parser.error(f"--sizes: expected at least {fewest} nodes each, got {args.sizes}")
    print(
        f"a {'-'.join(STAGES)} task, {args.per_node} native modules per node, a report every "
        f"{PERIOD * 1e3:g} ms per node, a decision look every {PERIOD * 1e3:g} ms; the manager "
        f"declares a node lost after {SILENCE} report periods without a word"
    )
    rows = []
    for size in args.sizes:
        rows.append(measure(size, args.seconds, args.per_node))
        print(f"  {size} nodes measured ({module_name(STAGES[0], 0)} repaired)", flush=True)
    print("(per node: control and report bytes/s, each node's % of one core; the manager's %)")
    print_table(rows)
    if not print_goals(rows[-1]):
        print("a goal was missed")


if __name__ == "__main__":
    main()
