"""What a plant sees of a run (`refresh.manager.plant.View`): ports read with one request per
robot, in the order asked, whatever robots they are on."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, cast

from refresh.manager.plant import View


class Nodes:
    """An applier's reads, counted: each robot's ports hold their own name's length."""

    def __init__(self) -> None:
        self.requests: list[tuple[str, tuple[str, ...]]] = []

    def reads(self, robot: str, ports: Sequence[str]) -> list[float]:
        self.requests.append((robot, tuple(ports)))
        return [float(len(robot) * 100 + len(port)) for port in ports]


def test_ports_on_two_robots_cost_one_request_each_and_come_back_in_order() -> None:
    nodes = Nodes()
    view = View(cast(Any, None), cast(Any, nodes))
    asked = [("a", "P.x"), ("bb", "Q.long"), ("a", "P.yy"), ("a", "P.x")]
    assert view.reads(*asked) == [103.0, 206.0, 104.0, 103.0]
    assert nodes.requests == [("a", ("P.x", "P.yy")), ("bb", ("Q.long",))]
