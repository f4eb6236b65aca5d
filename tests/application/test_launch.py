"""The launcher's watch of the processes of a run: a node the scenario kills may end, but once
it is started again its second run is watched as any other process's."""

from __future__ import annotations

import pytest

from application.launch import Launch, _listening_again, _Restart
from commandline.children import ChildError


def test_a_killed_node_may_end_but_not_once_it_is_started_again(tmp_path):
    launch = Launch(tmp_path)
    try:
        killed = launch.start("rotation", "-c", "raise SystemExit(-9 % 256)")
        killed.wait()
        launch.check("rotation")  # the scenario's kill: no error
        _Restart(launch, "rotation", ["-c", "raise SystemExit(3)"])()
        (again,) = launch.children
        assert again is not killed and again.log == tmp_path / "rotation-2.log"
        again.wait()
        with pytest.raises(ChildError, match="process rotation ended early with status 3"):
            launch.check("rotation")
    finally:
        launch.stop()


def test_a_node_started_again_listens_on_the_port_the_system_picked_for_its_first_run():
    first = ["-m", "patrol", "node", "--listen", "tcp-listen://127.0.0.1:0", "--flash", "f"]
    again = _listening_again(first, "socket://127.0.0.1:40123")
    assert again == [
        "-m",
        "patrol",
        "node",
        "--listen",
        "tcp-listen://127.0.0.1:40123",
        "--flash",
        "f",
    ]
    on_a_pty = ["-m", "patrol", "node", "--listen", "pty", "--flash", "f"]
    assert _listening_again(on_a_pty, "/dev/pts/3") == on_a_pty
