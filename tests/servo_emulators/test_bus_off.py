"""A bus-off controller leaves the bus cleanly however its inner bus ends: over a remote server
that went away first (the servos' process stopped before a node's), its shutdown raises nothing
and leaves both buses shut down (it raised ``Transport endpoint is not connected`` out of the
node's exit, and python-can warned that neither was shut down)."""

from __future__ import annotations

from can.interfaces.virtual import VirtualBus

from servo_emulators.bus_off import BusOffController


class GoneServer(VirtualBus):
    """A remote bus whose server went away first: its shutdown raises, as python-can-remote's."""

    def shutdown(self) -> None:
        raise OSError(107, "Transport endpoint is not connected")


def test_shutting_down_over_a_server_that_is_gone_raises_nothing_and_leaves_both_shut():
    inner = GoneServer(channel="gone")
    controller = BusOffController(inner)
    controller.shutdown()  # raised OSError out of the node's exit, both buses left unshut
    assert inner._is_shutdown and controller._is_shutdown
