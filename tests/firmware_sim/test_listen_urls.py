"""`firmware-sim listen --listen URL`: a CAN URL gets the node's side unless it names one."""

from __future__ import annotations

import pytest

from hexmigrate.links.listening import node_side


@pytest.mark.parametrize(
    ("url", "expected"),
    [
        ("can://virtual/bench", "can://virtual/bench?role=node"),
        ("can://virtual/bench?bitrate=250000", "can://virtual/bench?bitrate=250000&role=node"),
        ("can://virtual/bench?role=host", "can://virtual/bench?role=host"),
        ("faulty+can://virtual/bench#drop=0.1", "faulty+can://virtual/bench?role=node#drop=0.1"),
        ("faulty+can://virtual/bench", "faulty+can://virtual/bench?role=node"),
        ("faulty+can://virtual/b?role=node#seed=2", "faulty+can://virtual/b?role=node#seed=2"),
        ("tcp-listen://127.0.0.1:0", "tcp-listen://127.0.0.1:0"),
        ("faulty+loop://#drop=0.1", "faulty+loop://#drop=0.1"),
    ],
)
def test_a_listening_node_takes_the_node_side_of_a_can_link(url, expected):
    assert node_side(url) == expected
