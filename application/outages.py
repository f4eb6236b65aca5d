"""A node's outage, as each side of a run makes it happen (`application.recording.Outages`).

- In process (`SwitchedOff`): a killed node and a cut one alike are switched off, every PBO
  stopped, and come back switched on, their flash kept and their PBOs off; the runtime finds
  them lost, then back, on its own.
- Across processes (`OverLinks`): a cut is a `Relay` between the manager and the node, cut and
  restored at the scenario's times (`over_links` makes it, and checks the URLs the outages
  need, before the guests are built and the nodes opened); a kill is the node's own doing (it
  sends itself SIGKILL at the outage's time on its clock: `application.node`), and the
  launcher starts it again as soon as it died (wall time) when the scenario brings it back.
  Either way the node counts as down until the outage's end in the run's time
  (`ApplierBase.down`: the runtime does not try it before); then the manager waits (bounded,
  `BACK_TIMEOUT`) until the node can be reached, so that the runtime's next try finds it back
  at the same time of the run on every run.
"""

from __future__ import annotations

import contextlib
import socket
import time
from collections.abc import Callable, Mapping

from application.errors import RunError, ScenarioError
from application.relay import Relay
from application.scenario import Outage, Scenario
from hexmigrate.errors import LinkUrlError
from hexmigrate.links.tcp_client import parse_url
from refresh.appliers.in_process import NodeApplier
from refresh.manager.plant import View

BACK_TIMEOUT = 60.0
"""Seconds the manager waits at most for a node to be reachable when its outage ends (a
restarted node imports numpy and Unicorn first)."""


class SwitchedOff:
    """Outages in process: the node is switched off, then on (`NodeApplier.power_off`)."""

    def __init__(self, applier: NodeApplier) -> None:
        self.applier = applier

    def lose(self, view: View, outage: Outage) -> None:
        self.applier.power_off(outage.robot, "killed" if outage.kind == "kill" else "its link cut")

    def restore(self, view: View, outage: Outage) -> None:
        self.applier.power_on(outage.robot)


class OverLinks:
    """Outages across processes: `urls` is where the manager reaches each robot's node (a
    relay's URL for one whose link a scenario cuts), `relays` the relays by robot; `supervise`
    is called while a node is waited for (the launcher's watch, which starts a killed node
    again and fails the run at once when a process ended that should not have)."""

    def __init__(
        self,
        urls: Mapping[str, str],
        relays: Mapping[str, Relay],
        supervise: Callable[[], None] = lambda: None,
    ) -> None:
        self.urls = dict(urls)
        self.relays = dict(relays)
        self.supervise = supervise

    def lose(self, view: View, outage: Outage) -> None:
        view.applier.down.add(outage.robot)
        if outage.kind == "cut":
            self.relays[outage.robot].cut()

    def restore(self, view: View, outage: Outage) -> None:
        if outage.kind == "cut":
            self.relays[outage.robot].restore()
        reachable(self.urls[outage.robot], BACK_TIMEOUT, self.supervise)
        view.applier.down.discard(outage.robot)


def over_links(
    scenario: Scenario,
    nodes: Mapping[str, str],
    stack: contextlib.ExitStack,
    supervise: Callable[[], None] = lambda: None,
) -> OverLinks:
    """The outages of `scenario` on the nodes at `nodes` (robot -> URL): a relay to the node
    whose link it cuts (closed with `stack`), reached instead of the node. The URL of the node
    whose link the scenario cuts, or that it brings back, is checked now, before anything is
    built: a relay connects to it, and the manager waits for it over TCP (`reachable`), so it
    must be a ``socket://HOST:PORT`` URL."""
    outage = scenario.outage
    urls = dict(nodes)
    if outage is None or (outage.kind != "cut" and outage.back is None):
        return OverLinks(urls, {}, supervise)
    why = "to cut its link" if outage.kind == "cut" else "to wait for it to come back"
    url = nodes.get(outage.robot)
    if url is None:
        raise ScenarioError(
            f"scenario {scenario.name}: expected an outage of one of {', '.join(nodes)}, got "
            f"{outage.robot}"
        )
    try:
        host, port = parse_url(url)
    except LinkUrlError as error:
        raise ScenarioError(
            f"scenario {scenario.name}: robot {outage.robot}'s node: expected a "
            f"socket://HOST:PORT URL, {why}: {error}"
        ) from error
    if outage.kind != "cut":
        return OverLinks(urls, {}, supervise)
    relay = Relay(host, port)
    stack.callback(relay.close)
    urls[outage.robot] = relay.url
    return OverLinks(urls, {outage.robot: relay}, supervise)


def reachable(url: str, timeout: float, between: Callable[[], None] = lambda: None) -> None:
    """Return once a TCP connection to `url` (``socket://HOST:PORT``, checked by `over_links`)
    is accepted and stays open a moment (a relay that is down accepts and closes at once); a
    RunError after `timeout` seconds. `between` is called before each try."""
    address = parse_url(url)
    deadline = time.monotonic() + timeout
    while True:
        between()
        with contextlib.suppress(OSError), socket.create_connection(address, 0.5) as probe:
            probe.settimeout(0.1)
            try:
                if probe.recv(1) != b"":  # anything but an orderly close: the link is up
                    return
            except TimeoutError:
                return
        if time.monotonic() >= deadline:
            raise RunError(f"the node at {url}: not reachable after {timeout:g} s")
        time.sleep(0.1)
