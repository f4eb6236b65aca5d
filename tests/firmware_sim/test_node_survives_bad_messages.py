"""A listening node process that hears malformed messages refuses them and keeps serving.

A blank line typed on a terminal, or a frame whose CRC is right but whose body is garbage, used
to end the node process. The node is started as every node process of the project is
(`firmware_sim.serving.node_process.NodeProcess`), so a change of the node command is made there
once.
"""

from __future__ import annotations

import struct
import zlib

from firmware_sim.serving.node_process import NodeProcess
from hexmigrate.elf import image_from_elf
from hexmigrate.links import open_link
from hexmigrate.transfer.messages import Nak, decode
from hexmigrate.transfer.sender import Sender
from tests.firmware_sim.host_side import check_node_output

ANSWER_TIMEOUT = 10.0
CONNECT_LINE = r"\(connect with: hexmigrate send FILE\.hex --to (socket://127\.0\.0\.1:\d+)\)$"
GARBAGE_LISTING = b"\x12gain@0x20000"  # a LISTING (0x12) whose module has no size


def test_a_listening_node_refuses_a_blank_line_and_a_garbage_listing_and_keeps_serving(
    example_builds,
):
    image = image_from_elf(example_builds["gain"].elf)
    with NodeProcess(
        "tcp-listen://127.0.0.1:0", "--set", "gain.k=0x20000", "--show", "gain.y"
    ) as node:
        listening = node.wait_for(CONNECT_LINE)
        with open_link(listening[1]) as link:
            for raw in (b"   ", GARBAGE_LISTING + struct.pack("<I", zlib.crc32(GARBAGE_LISTING))):
                link.send(raw)
                reply = link.receive(ANSWER_TIMEOUT)
                assert reply is not None, f"no answer to {raw!r}:\n{node.lines()}"
                refusal = decode(reply, checked=True)
                assert isinstance(refusal, Nak), refusal
                assert refusal.reason.startswith("bad message: "), refusal.reason
            sender = Sender(link, "binary", timeout=ANSWER_TIMEOUT, retries=0)
            assert sender.ping().startswith("node: 0 module(s)")
            assert sender.send(image).name == "gain"
        check_node_output(node, ["gain"])
        assert node.child.process.poll() is None, node.lines()
