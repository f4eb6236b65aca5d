"""In-order scoreboard: each output port must carry exactly the model's beats, in order.

Every expected beat remembers which input it came from and its number there, so a failure says
which beat went wrong. Lost beats show as leftovers, extra or duplicated beats as unexpected
arrivals, reordered or wrongly processed beats as mismatches.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from ..model import Beat


@dataclass(frozen=True)
class Expected:
    """A beat the model predicts, and where it came from."""

    beat: Beat
    input: int
    number: int


class Scoreboard:
    """Expected beats per output port, compared as the DUT delivers them."""

    def __init__(self, ports: int) -> None:
        self.expected: list[deque[Expected]] = [deque() for _ in range(ports)]
        self.errors: list[str] = []
        self.matched = [0] * ports

    def expect(self, port: int, item: Expected) -> None:
        """The model says ``item`` will leave at ``port``."""
        self.expected[port].append(item)

    def observe(self, port: int, beat: Beat, cycle: int) -> None:
        """The DUT delivered ``beat`` at ``port`` at ``cycle``."""
        if not self.expected[port]:
            self.errors.append(f"cycle {cycle}: out{port} delivered {beat} that no input sent")
            return
        item = self.expected[port].popleft()
        if item.beat != beat:
            self.errors.append(
                f"cycle {cycle}: out{port} beat {self.matched[port]} expected {item.beat} "
                f"(in{item.input} beat {item.number}), got {beat}"
            )
        self.matched[port] += 1

    def pending(self) -> int:
        """Beats the model predicted that have not arrived."""
        return sum(len(queue) for queue in self.expected)

    def check_so_far(self) -> None:
        """Raise AssertionError on any mismatch or unexpected beat seen so far."""
        if self.errors:
            raise AssertionError("scoreboard: " + "; ".join(self.errors[:5]))

    def check(self) -> None:
        """Raise AssertionError on any mismatch, unexpected or missing beat."""
        missing = [f"out{p}: {len(q)} beats" for p, q in enumerate(self.expected) if q]
        problems = self.errors[:5] + ([f"never delivered: {', '.join(missing)}"] if missing else [])
        if problems:
            raise AssertionError("scoreboard: " + "; ".join(problems))
