"""The C node's frame writer (firmware/protocol/binary_frame.c) writes a binary answer on the link
as it is made, one COBS run at a time, so its frames must be byte for byte what hexmigrate's
`cobs_encode` makes of the whole message: the host's deframer takes nothing else, and the
canonical form matters where a run of 254 bytes meets a 0x00 or the message's end. The file is
compiled for the host and driven through ctypes, the message fed in pieces of any size, as the
node's encoder feeds it field by field."""

from __future__ import annotations

import ctypes
import subprocess
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hexmigrate.links.framing import cobs_encode

SOURCE = Path(__file__).resolve().parents[2] / "firmware" / "protocol" / "binary_frame.c"
Send = ctypes.CFUNCTYPE(None, ctypes.c_char_p, ctypes.c_size_t)


@pytest.fixture(scope="module")
def library(tmp_path_factory) -> ctypes.CDLL:
    built = tmp_path_factory.mktemp("frame") / "libframe.so"
    subprocess.run(
        ["gcc", "-shared", "-fPIC", "-O1", "-Wall", "-Werror", "-o", str(built), str(SOURCE)],
        check=True,
    )
    library = ctypes.CDLL(str(built))
    library.frame_writer_start.argtypes = [ctypes.c_void_p, Send]
    library.frame_writer_put.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_size_t]
    library.frame_writer_end.argtypes = [ctypes.c_void_p]
    return library


def written(library: ctypes.CDLL, message: bytes, cuts: list[int]) -> bytes:
    """What the writer sends for `message`, put in pieces ending at `cuts`."""
    sent = bytearray()
    send = Send(lambda data, length: sent.extend(ctypes.string_at(data, length)))
    writer = ctypes.create_string_buffer(512)  # struct frame_writer is under 300 bytes
    library.frame_writer_start(writer, send)
    start = 0
    for end in [*sorted(cut for cut in cuts if cut <= len(message)), len(message)]:
        library.frame_writer_put(writer, message[start:end], end - start)
        start = end
    library.frame_writer_end(writer)
    return bytes(sent)


RUN = bytes(range(1, 255))
"""254 non-zero bytes: one full COBS run."""


@pytest.mark.parametrize(
    "message",
    [b"", b"\x00", b"\x00\x00", RUN, RUN + b"\x00", RUN + b"\x00\x01", RUN * 2, RUN + b"\x01"],
    ids=["empty", "zero", "zeros", "run", "run-zero", "run-zero-byte", "two-runs", "run-byte"],
)
def test_a_frame_at_a_run_s_edges_is_the_canonical_one(library, message):
    assert written(library, message, []) == b"\x00" + cobs_encode(message) + b"\x00"


@settings(max_examples=300)
@given(
    message=st.binary(max_size=1100)
    | st.lists(st.sampled_from([0, 1, 255]), max_size=600).map(bytes),
    cuts=st.lists(st.integers(0, 1100), max_size=8),
)
def test_any_message_put_in_any_pieces_is_framed_as_the_host_frames_it(library, message, cuts):
    assert written(library, message, cuts) == b"\x00" + cobs_encode(message) + b"\x00"
