"""The host's side of lock-step virtual time: a `TimeMaster` grants every node the same quantum.

Each node runs ``firmware-sim listen --lock-step``: its clock moves only when an Advance says
(`NodeControl.advance`). The master grants quanta one after another; for each it asks every node
at once (the caller's thread asks the first, a thread of the master's each other one: a hand-off
between threads less per quantum) to run to the quantum's end, and waits for all of them. A
value a node sends over a bridge during quantum k reaches the importing node at the start of
quantum k+1: the master tells the importer how many values the exporter had sent by the end of
quantum k (the count the exporter acknowledged), and the importer waits for that very value
before it runs and takes none beyond it (firmware_sim's `KernelControl.advance`). So what each
node sees does not depend on when TCP delivered it, and a run is reproducible; messages between
nodes are delivered at quantum boundaries, as Renode synchronises its machines.

A node sends the reports and heartbeats its watch made due by the quantum's end before it
answers the Advance, on the same link (`Receiver.handle`): once the master has every node's
answer, a host that reads those links (refresh's manager, whose sender files what comes before
an answer) holds every report of the quantum, with no round trip more to make sure.

A device the nodes reach during a quantum in a process of its own (a servo emulator on a CAN
bus) is not granted quanta: it follows the time each node stamps on what it sends (the end of
the node's quantum: `servo_emulators.lock_step`), with no message more per quantum.

Times are counted in whole microseconds (what an Advance carries), so that the nodes' clocks
and the master's `now` are the same numbers.

The master's threads (one per node but the first) live as long as it does, not one `run_until`:
a caller that runs the world a frame at a time would otherwise start two threads a frame.
`close` ends them, and so does the master's collection.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor, wait

from hexmigrate.errors import HexmigrateError, LockStepError, TransferError
from hexmigrate.transfer.control import MICROSECONDS
from hexmigrate.transfer.control_client import NodeControl


class TimeMaster:
    """Lock-step time for the nodes `controls` (name -> its control), `quantum` seconds at a
    time. Each NodeControl is used by the master's threads while `run_until` runs: nothing else
    may use it then, and `run_until` returns or raises (Ctrl-C included) only once every
    Advance it asked for has ended. A context manager; `close` may be called twice."""

    def __init__(
        self,
        controls: Mapping[str, NodeControl],
        quantum: float,
    ) -> None:
        if not (math.isfinite(quantum) and round(quantum * MICROSECONDS) >= 1):
            raise LockStepError(f"expected a quantum of at least 1 microsecond, got {quantum!r} s")
        if not controls:
            raise LockStepError("expected at least one node to grant time to, got none")
        self.controls = dict(controls)
        self.quantum = quantum
        self._quantum_us = round(quantum * MICROSECONDS)
        self._now_us = 0
        self.routes: dict[int, tuple[str, str]] = {}
        """Bridge number -> (exporting node, importing node)."""
        self.counts: dict[int, int] = {}
        """Bridge number -> values its exporter had sent at the end of the last quantum."""
        self.clocks: dict[str, float] = dict.fromkeys(self.controls, 0.0)
        """Node name -> the clock it acknowledged at the end of the last quantum."""
        self._here, *self._others = self.controls
        """The node the caller's thread advances, and those the master's threads advance."""
        self._pool = ThreadPoolExecutor(
            max(1, len(self.controls) - 1), thread_name_prefix="time master"
        )
        self._release = weakref.finalize(self, self._pool.shutdown, wait=False)
        """Ends the threads, idle between quanta: on `close`, or when the master is collected."""

    @property
    def now(self) -> float:
        """The time every node has reached, in seconds."""
        return self._now_us / MICROSECONDS

    def route(self, number: int, source: str, sink: str) -> None:
        """Bridge `number` carries values from node `source` to node `sink`."""
        for node in (source, sink):
            if node not in self.controls:
                known = ", ".join(self.controls)
                raise LockStepError(f"bridge {number}: expected a node among {known}, got {node!r}")
        if number in self.routes:
            raise LockStepError(f"bridge {number} is routed already: {self.routes[number]}")
        self.routes[number] = (source, sink)
        self.counts[number] = 0

    def unroute(self, number: int) -> None:
        """Forget bridge `number` (taken down)."""
        self.routes.pop(number, None)
        self.counts.pop(number, None)

    def run_until(self, t: float) -> None:
        """Grant quanta to every node until they all reached `t` (the last quantum is cut short
        when `t` is not a whole number of them). A time that is not a finite number of
        microseconds is refused (LockStepError) before any quantum is granted."""
        if not self._release.alive:
            raise LockStepError(f"run to {t:g} s: expected an open time master, got a closed one")
        if not math.isfinite(t * MICROSECONDS):
            raise LockStepError(f"run to a time: expected a finite number of seconds, got {t!r}")
        target = round(t * MICROSECONDS)
        while self._now_us < target:
            until = min(self._now_us + self._quantum_us, target)
            self._grant(until)
            self._now_us = until

    def close(self) -> None:
        """Let the master's threads end (each as soon as it is idle: between two `run_until`
        calls, at once); a closed master grants no more quanta."""
        self._release()

    def __enter__(self) -> TimeMaster:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _grant(self, until_us: int) -> None:
        """Run every node to `until_us`, each expecting the values sent by the last quantum's
        end; then note what the exporters sent during this one."""
        until = until_us / MICROSECONDS
        here = self._here
        futures = {
            name: self._pool.submit(self.controls[name].advance, until, self._expected(name))
            for name in self._others
        }
        results: dict[str, tuple[float, dict[int, int]]] = {}
        failures = []
        try:
            try:  # one node in this thread, while the pool's threads advance the others
                results[here] = self.controls[here].advance(until, self._expected(here))
            except HexmigrateError as error:
                failures.append(f"node {here}: {error}")
            for name, future in futures.items():
                try:
                    results[name] = future.result()
                except HexmigrateError as error:
                    failures.append(f"node {name}: {error}")
        finally:  # on Ctrl-C or a bug too: no Advance left running on a control the caller uses
            wait(futures.values())
        if failures:
            raise TransferError(f"quantum to {until:g} s: " + "; ".join(failures))
        for name, (clock, counts) in results.items():
            self.clocks[name] = clock
            if clock < until:
                raise TransferError(
                    f"node {name}: expected its clock at {until:g} s, got {clock:g}"
                )
            for number, (source, _) in self.routes.items():
                if source == name and number in counts:
                    self.counts[number] = counts[number]

    def _expected(self, name: str) -> dict[int, int]:
        """{bridge number: value to wait for} of the bridges node `name` imports."""
        return {
            number: self.counts[number] for number, (_, sink) in self.routes.items() if sink == name
        }
