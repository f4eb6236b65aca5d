"""`--scheduler` reaches only a Dask scheduler: what else listens there (a server that accepts and
says nothing, one that sends bytes of its own, a closed port) is one CampaignError within the
scheduler's timeout, never a hang nor an exception from Dask's decoders."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from campaign import engine
from campaign.errors import CampaignError

TIMEOUT = 1.0


@contextmanager
def server(answer: bytes | None) -> Iterator[str]:
    """A TCP server on loopback that sends `answer` to each client (None: nothing) and keeps
    it open; its tcp:// address."""
    listener = socket.create_server(("127.0.0.1", 0))
    listener.settimeout(0.1)
    stop = threading.Event()
    held: list[socket.socket] = []

    def serve() -> None:
        while not stop.is_set():
            try:
                client, _ = listener.accept()
            except TimeoutError:
                continue
            held.append(client)
            if answer is not None:
                client.sendall(answer)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{listener.getsockname()[1]}"
    finally:
        stop.set()
        thread.join(5)
        for client in held:
            client.close()
        listener.close()


@pytest.mark.timeout(30)
@pytest.mark.parametrize(
    ("answer", "said"),
    [
        (None, f"no answer in {TIMEOUT:g} s"),
        (b"\xff" * 64 + b"\x1b[31mEVIL\n" * 10, "an answer Dask cannot read"),
        (b"\x08" + b"\xff" * 7 + b"\x00" * 64, "an answer Dask cannot read"),
        (b"HTTP/1.1 200 OK\r\n\r\n", "an answer Dask cannot read"),
    ],
    ids=["silent", "garbage", "huge-length", "http"],
)
def test_a_server_that_is_no_scheduler_is_one_error_in_time(monkeypatch, answer, said):
    monkeypatch.setattr(engine, "SCHEDULER_TIMEOUT", TIMEOUT)
    with server(answer) as address:
        begun = time.monotonic()
        expected = r"--scheduler: expected a Dask scheduler at "
        with pytest.raises(CampaignError, match=expected) as e, engine.client(1, address):
            pass
    assert said in str(e.value)
    assert time.monotonic() - begun < 3 * TIMEOUT + 2


@pytest.mark.timeout(30)
def test_a_closed_port_is_one_error(monkeypatch):
    monkeypatch.setattr(engine, "SCHEDULER_TIMEOUT", TIMEOUT)
    with socket.create_server(("127.0.0.1", 0)) as taken:
        address = f"tcp://127.0.0.1:{taken.getsockname()[1]}"
    expected = r"expected a Dask scheduler at tcp://127\.0\.0\.1:"
    with pytest.raises(CampaignError, match=expected), engine.client(1, address):
        pass


@pytest.mark.timeout(60)
def test_a_dask_scheduler_is_taken():
    from distributed import LocalCluster

    with (
        LocalCluster(
            n_workers=0, processes=False, protocol="tcp", host="127.0.0.1", dashboard_address=None
        ) as cluster,
        engine.client(1, cluster.scheduler_address) as client,
    ):
        assert client.scheduler_info()["address"] == cluster.scheduler_address
