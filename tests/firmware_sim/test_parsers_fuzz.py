"""The servo emulators' parsers and the SLCAN device take whatever a host sends.

A hostile or broken host may send any bytes: the SSC-32 controller ignores what is not a
command (counted in `ignored`) and keeps its line buffer bounded, the CAN servo nodes ignore
frames they cannot decode, and the SLCAN adapter answers BELL to what it cannot do. None raises,
and each still obeys a valid command afterwards.
"""

from __future__ import annotations

import can
from hypothesis import given, settings
from hypothesis import strategies as st

from hexmigrate.links.slcan_device import BELL, SlcanDevice
from servo_emulators.can_servo import CanServoNodes
from servo_emulators.ssc32 import MAX_LINE, Ssc32

FUZZ = settings(max_examples=200, derandomize=True)
ssc32_text = st.text(alphabet="#PSTLHVQAB0123456789-+ \r\x1b,.:", max_size=300)


@FUZZ
@given(st.one_of(st.binary(max_size=3000), ssc32_text.map(str.encode)))
def test_the_ssc32_takes_any_bytes_and_still_obeys_a_command(data: bytes) -> None:
    controller = Ssc32(now=lambda: 0.0)
    controller.feed(data)
    assert len(controller._line) <= MAX_LINE
    assert controller.feed(b"\x1bVER\r").startswith(b"SSC32")


@FUZZ
@given(
    st.integers(0, (1 << 29) - 1),
    st.binary(max_size=8),
    st.booleans(),
    st.booleans(),
)
def test_the_can_servo_nodes_take_any_frame(identifier, data, extended, remote) -> None:
    nodes = CanServoNodes(now=lambda: 0.0)
    frame = can.Message(
        arbitration_id=identifier if extended else identifier & 0x7FF,
        data=data,
        is_extended_id=extended,
        is_remote_frame=remote,
    )
    for answer in nodes.handle(frame):
        assert isinstance(answer, can.Message)
    nodes.due()


def test_the_slcan_device_answers_any_command_without_raising() -> None:
    @FUZZ
    @given(st.text(max_size=80))
    def one(command: str) -> None:
        reply = device.handle(command)
        assert reply == BELL or reply.endswith(b"\r"), (command, reply)

    with SlcanDevice("slcan-fuzz") as device:
        one()
        assert device.handle("C") in (BELL, b"\r")
        assert device.handle("S6") == b"\r"
