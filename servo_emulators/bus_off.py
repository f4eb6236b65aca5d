"""A host CAN controller that can go bus-off: a python-can bus wrapper for fault injection.

A CAN controller whose transmit error counter passes 255 (a shorted bus, a missing terminator)
leaves the bus: it sends nothing until it recovers, and python-can back ends for real adapters
then refuse `send` with `CanOperationError` and report `BusState.ERROR`. python-can's virtual bus
never does; wrapping it in `BusOffController` and calling `bus_off()` makes it behave so.
"""

from __future__ import annotations

import time

import can
from can.bus import BusState

from hexmigrate.links.can import shut_down

BUS_OFF_REASON = "bus-off: transmit error counter passed 255, the controller left the bus"


class BusOffController(can.BusABC):
    """`inner` as it is, until `bus_off()`; then sends fail and nothing is received."""

    def __init__(self, inner: can.BusABC) -> None:
        self.inner = inner
        self._off = False
        super().__init__(channel=getattr(inner, "channel_info", "inner"))
        self.channel_info = f"bus-off wrapper of {inner.channel_info}"

    def bus_off(self) -> None:
        """Leave the bus, as a controller whose error counter ran over."""
        self._off = True

    @property
    def state(self) -> BusState:
        return BusState.ERROR if self._off else BusState.ACTIVE

    @state.setter
    def state(self, new_state: BusState) -> None:
        raise NotImplementedError("the state follows bus_off()")

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        if self._off:
            raise can.CanOperationError(BUS_OFF_REASON)
        self.inner.send(msg, timeout)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        if self._off:
            time.sleep(timeout or 0.0)
            return None, False
        return self.inner.recv(timeout), False

    def shutdown(self) -> None:
        """Shut the inner bus down, also when its remote server is gone already (the servos'
        process stopped first at the end of a run: its shutdown raised and left both buses
        unshut, with python-can's warnings on the node's log), then this wrapper."""
        try:
            shut_down(self.inner)
        finally:
            super().shutdown()
