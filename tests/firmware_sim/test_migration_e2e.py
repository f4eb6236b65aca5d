"""End to end: a module crosses a real transport to a node, is installed there, and runs.

Two processes where the transport joins processes (a pty pair, TCP to a ``tcp-listen://`` node,
CAN through a python-can-remote server, SLCAN on a pty): the node is ``firmware-sim listen
--listen URL`` (a `firmware_sim.serving.node_process.NodeProcess`) or the host is ``hexmigrate
send``/``ls``/``ping``/``rm``, each a subprocess, as a user would run them; the node's output
(its "listening on" line first, registrations, ``--show`` values) is read as it comes. The pty
node is restarted on its flash file to boot what it got. In one process (``can://virtual``;
``loop://``, shared by both as two stations) the node is served by
`firmware_sim.serving.serve.serve` in a thread of its own: the node (and its Unicorn CPU) is
made, used and closed in that thread only, and the test thread holds nothing but the sender and
its link. Then faults: 1 % corruption
and drops in both directions, and a link cut mid-transfer that `Sender.resume` completes on a new
link while the node keeps its `Receiver`.

Every wait is bounded; every subprocess is terminated (and killed if need be) in a finally.
Everything stays on 127.0.0.1.
"""

from __future__ import annotations

import contextlib
import queue
import re
import socket
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import pytest

from commandline.children import Child
from firmware_sim.core.natives import Signal
from firmware_sim.core.node import Node
from firmware_sim.core.transfer_target import NodeTarget
from firmware_sim.serving.node_process import NodeProcess
from firmware_sim.serving.serve import serve
from hexmigrate.elf import image_from_elf
from hexmigrate.errors import TransferInterrupted
from hexmigrate.image import ModuleImage
from hexmigrate.links import LinkBase, open_link
from hexmigrate.links.faulty import FaultyLink
from hexmigrate.links.remote_server import RemoteCanServer
from hexmigrate.links.shared import SharedLine
from hexmigrate.links.slcan_device import SlcanDevice
from hexmigrate.links.tcp import MAX_CLIENTS, TcpListenLink
from hexmigrate.transfer.receiver import Receiver
from hexmigrate.transfer.sender import Sender
from pbort.errors import KernelError
from pbort.native import NativeModule
from tests.firmware_sim.host_side import CLI_TIMEOUT, GAIN_SHOWN, check_node_output, hexmigrate

THREAD_TIMEOUT = 10.0
RUN_TIMEOUT = 10.0
"""How long to wait for an installed module's output to show that it runs."""
GAIN_K = 0x20000  # 2.0 in Q16.16: gain refuses to start with k == 0
RAMP_STEP = 21  # the native signal's ramp: 21, 42, 63, ...
RATE = 100.0
FAULTS = "corrupt=0.01&drop=0.01"
MAX_FAULTY_ROUNDS = 20
GAIN_SET = ("--set", f"gain.k={GAIN_K:#x}")


def unique(prefix: str) -> str:
    """A CAN channel name no other test uses (python-can's virtual buses are per process)."""
    return f"{prefix}-{uuid.uuid4().hex[:8]}"


@pytest.fixture(scope="module")
def images(example_builds) -> dict[str, ModuleImage]:
    return {name: image_from_elf(build.elf) for name, build in example_builds.items()}


class NodeThread:
    """A node served by `serve` in a thread of its own, on each of `urls` (a URL, or a function
    that opens a link) in turn with one
    `Receiver` (`advance` moves it to the next link). Only that thread touches the node: it
    starts each module it installs (gain behind a native ramp signal), copies the values of the
    watched ports to `values` after every message, and fills `report` when it stops."""

    WATCHED = ("signal.y", "gain.y")

    def __init__(
        self, urls: Iterable[str | Callable[[], LinkBase]], images: dict[str, ModuleImage]
    ) -> None:
        self.urls = list(urls)
        self.images = images
        self.values: dict[str, int] = {}
        self.installed: list[tuple[str, int]] = []
        self.report: dict[str, Any] = {}
        self.link: LinkBase | None = None
        self.error: BaseException | None = None
        self._opened: queue.SimpleQueue[str] = queue.SimpleQueue()
        self._next = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="node", daemon=True)

    def __enter__(self) -> NodeThread:
        self._thread.start()
        try:
            self._wait_open()
        except BaseException:
            self.stop(check=False)
            raise
        return self

    def __exit__(self, exc_type: object, *exc_info: object) -> None:
        self.stop(check=exc_type is None)

    def advance(self) -> None:
        """Close the link served now and serve the next one (same node, same Receiver)."""
        self._next.set()
        self._wait_open()

    def stop(self, check: bool = True) -> None:
        """End the thread; re-raise what failed in it."""
        self._stop.set()
        self._thread.join(timeout=THREAD_TIMEOUT)
        if check:
            assert not self._thread.is_alive(), "the node thread did not stop"
            if self.error is not None:
                raise self.error

    def wait_running(self) -> int:
        """gain.y once it is positive: gain runs on the node, fed by the ramp."""
        deadline = time.monotonic() + RUN_TIMEOUT
        while time.monotonic() < deadline and self._thread.is_alive():
            value = self.values.get("gain.y", 0)
            if value > 0:
                assert value % (2 * RAMP_STEP) == 0, f"gain.y = {value}: not 2.0 x the ramp"
                return value
            time.sleep(0.01)
        raise AssertionError(f"gain did not run: {self.values}, {self.error!r}")

    def _wait_open(self) -> None:
        deadline = time.monotonic() + THREAD_TIMEOUT
        while time.monotonic() < deadline:
            if self.error is not None:
                raise self.error
            try:
                self._opened.get(timeout=0.05)
            except queue.Empty:
                continue
            return
        raise AssertionError("the node thread did not open its link")

    def _run(self) -> None:
        try:
            with Node("e2e") as node:
                receiver = Receiver(NodeTarget(node, on_install=lambda n, a: self._start(node, n)))
                for url in self.urls:
                    with open_link(url) if isinstance(url, str) else url() as link:
                        self.link = link
                        self._next.clear()
                        self._opened.put(url)
                        serve(node, link, receiver=receiver, stop=lambda: self._watch(node))
                    if self._stop.is_set():
                        break
                self.report = self._inspect(node)
        except BaseException as error:
            self.error = error

    def _start(self, node: Node, name: str) -> None:
        """What `firmware-sim listen` does on a registration, with gain's input wired to a
        ramp."""
        self.installed.append((name, node.modules[name].load_address))
        if name != "gain":
            node.start(name, RATE)
            return
        if "signal" not in node.kernel.names:
            constants = {"shape": 0, "amplitude": RAMP_STEP}
            node.start(NativeModule(Signal), RATE, constants=constants)
        self.values.pop("gain.y", None)
        node.start("gain", RATE, constants={"k": GAIN_K})
        node.kernel.connect("signal.y", "gain.x")

    def _watch(self, node: Node) -> bool:
        for port in self.WATCHED:
            with contextlib.suppress(KernelError):  # not (or no longer) on the node
                self.values[port] = int(node.kernel.value(port))
        return self._next.is_set() or self._stop.is_set()

    def _inspect(self, node: Node) -> dict[str, Any]:
        """Where each module sits and whether its flash holds the image relocated there."""
        modules = {}
        for name, module in node.modules.items():
            image = self.images[name]
            flash = node.flash.read(module.load_address, image.size)
            modules[name] = (module.load_address, flash == image.relocate(module.load_address))
        return {"modules": modules, "values": dict(self.values)}


def assert_installed_and_ran(node: NodeThread, names: Iterable[str]) -> None:
    """After `node.stop()`: each module sits in flash as relocated for its address, gain ran."""
    expected = {name: (address, True) for name, address in node.installed if name in names}
    assert node.report["modules"] == expected
    assert node.report["values"]["gain.y"] > 0


# The tcp-listen link the TCP tests' node listens on.


def test_tcp_listen_serves_several_clients_at_once_each_on_its_own_stream():
    with open_link("tcp-listen://127.0.0.1:0") as server:
        assert isinstance(server, TcpListenLink)
        assert server.connect_url == f"socket://127.0.0.1:{server.port}"
        server.send(b"NOBODY THERE")  # a serial line with no cable: lost, not raised
        address = ("127.0.0.1", server.port)
        with socket.create_connection(address, timeout=5.0) as first:
            first.sendall(b"ONE\n")
            assert server.receive_from(5.0) == (1, b"ONE")
            with socket.create_connection(address, timeout=5.0) as second:
                first.sendall(b"\x00\x05\x01ab")  # a binary frame the first leaves cut short
                second.sendall(b"TWO\n")  # served while the first is still connected
                assert server.receive_from(5.0) == (2, b"TWO")  # not joined to the first's
                server.send(b"HELLO")  # answers the client of the last message
                assert second.recv(64) == b"HELLO\n"
                server.send_to(1, b"FIRST")
                assert first.recv(64) == b"FIRST\n"
        assert (server.lost, server.connections) == (1, 2)


def test_a_client_past_the_limit_takes_the_place_of_the_one_silent_the_longest():
    with open_link("tcp-listen://127.0.0.1:0") as server, contextlib.ExitStack() as stack:
        assert isinstance(server, TcpListenLink)
        address = ("127.0.0.1", server.port)
        idle = [
            stack.enter_context(socket.create_connection(address, timeout=5.0))
            for _ in range(MAX_CLIENTS)
        ]
        for number, client in enumerate(idle[1:], start=2):  # all but the first speak
            client.sendall(b"HERE\n")
            assert server.receive_from(5.0) == (number, b"HERE")
        late = stack.enter_context(socket.create_connection(address, timeout=5.0))
        late.sendall(b"LATE\n")
        assert server.receive_from(5.0) == (MAX_CLIENTS + 1, b"LATE")
        assert idle[0].recv(64) == b""  # let go: it had said nothing since it connected
        idle[1].sendall(b"STILL\n")
        assert server.receive_from(5.0) == (2, b"STILL")


# Two processes.


@pytest.mark.slow
def test_a_pty_pair_between_two_processes(example_hex, tmp_path):
    flash = ("--flash", str(tmp_path / "flash.bin"))
    with NodeProcess(
        "pty", *GAIN_SET, "--show", "gain.y", "--show", "moving_average.y", *flash
    ) as node:
        index, listening = node.wait_for_line(r"^listening on (/dev/pts/\d+) ")
        pty = listening[1]
        assert index == 0
        assert (
            node.lines()[0]
            == f"listening on {pty} (connect with: hexmigrate send FILE.hex --to {pty})"
        )
        sent = hexmigrate("send", example_hex["gain"], "--to", pty, "--quiet", "--mode", "hex")
        assert "module gain installed at 0x" in sent
        hexmigrate("send", example_hex["moving_average"], "--to", pty, "--quiet")
        addresses = check_node_output(node, ["gain", "moving_average"])
        listing = hexmigrate("ls", "--to", pty).splitlines()
        assert [line.split()[:2] for line in listing] == [
            [name, f"0x{address:08X}"] for name, address in addresses.items()
        ]
        assert hexmigrate("ping", "--to", pty).startswith("node: 2 module(s), ")
        removed = hexmigrate("rm", "moving_average", "--to", pty, "--mode", "hex")
        assert removed == f"removed moving_average from {pty}\n"
        assert [line.split()[0] for line in hexmigrate("ls", "--to", pty).splitlines()] == ["gain"]
        index, _ = node.wait_for_line(r"moving_average\.y=\?$", start=len(node.lines()))
        node.wait_for(GAIN_SHOWN, start=index)  # gain still runs once moving_average is gone

    # The node again on the same flash: it says where it listens first, then boots gain.
    with NodeProcess("pty", *GAIN_SET, "--show", "gain.y", *flash) as node:
        node.wait_for(GAIN_SHOWN)
        assert re.fullmatch(r"listening on /dev/pts/\d+ \(connect with: .*\)", node.lines()[0])
        assert node.lines()[1] == f"registered gain at 0x{addresses['gain']:08X}"
        assert check_node_output(node, ["gain"]) == {"gain": addresses["gain"]}


def test_tcp_listen_between_two_processes_and_resume_after_a_cut(example_hex, images):
    with NodeProcess("tcp-listen://127.0.0.1:0", *GAIN_SET, "--show", "gain.y") as node:
        listening = node.wait_for(
            r"^listening on tcp-listen://127\.0\.0\.1:(\d+) \(connect with: hexmigrate send "
            r"FILE\.hex --to (socket://127\.0\.0\.1:(\d+))\)$"
        )
        port, to = listening[1], listening[2]
        assert port == listening[3] != "0"
        hexmigrate("send", example_hex["gain"], "--to", to, "--quiet", "--mode", "hex")
        check_node_output(node, ["gain"])

        # A cable pulled mid-transfer, then a new connection to the same node: RESUME.
        image = images["moving_average"]
        with (
            open_link(f"faulty+{to}#cut_after=800") as cut_link,
            pytest.raises(TransferInterrupted) as cut,
        ):
            Sender(cut_link, "binary", window=1).send(image)
        assert 0 < cut.value.programmed < image.size
        with open_link(to) as link:
            resumed = Sender(link, "binary").resume(image, cut.value.tid)
        assert resumed.name == "moving_average"
        assert resumed.wire_bytes < image.size  # the blocks the node had were not sent again
        assert [line.split()[0] for line in hexmigrate("ls", "--to", to).splitlines()] == [
            "gain",
            "moving_average",
        ]
        check_node_output(node, ["gain", "moving_average"])


def test_faults_on_both_ends_of_a_tcp_link_between_processes(example_hex):
    with NodeProcess(
        f"faulty+tcp-listen://127.0.0.1:0#{FAULTS}&seed=5", *GAIN_SET, "--show", "gain.y"
    ) as node:
        listening = node.wait_for(
            rf"^listening on faulty\+tcp-listen://127\.0\.0\.1:(\d+)#{FAULTS}&seed=5 "
            r"\(connect with: hexmigrate send FILE\.hex --to (socket://127\.0\.0\.1:\d+)\)$"
        )
        to = f"faulty+{listening[2]}#{FAULTS}&seed=6"
        for mode in ("hex", "binary"):
            sent = hexmigrate(
                "send", example_hex["gain"], "--to", to, "--quiet", "--mode", mode,
                "--timeout", "0.3", "--retries", "20",
            )  # fmt: skip
            assert "module gain installed at 0x" in sent
        check_node_output(node, ["gain"])


def test_can_through_a_remote_server_between_two_processes(example_hex, images):
    with (
        RemoteCanServer(unique("e2e-remote")) as server,
        NodeProcess(server.url(role="node"), *GAIN_SET, "--show", "gain.y") as node,
    ):
        node.wait_for(r"^listening on can://remote/127\.0\.0\.1:\d+/e2e-remote-\w+\?role=node$")
        hexmigrate("send", example_hex["gain"], "--to", server.url(), "--quiet")
        with open_link(server.url()) as link:
            sender = Sender(link, "hex")
            assert sender.send(images["moving_average"]).name == "moving_average"
            assert [m.name for m in sender.modules()] == ["gain", "moving_average"]
            assert sender.ping().startswith("node: 2 module(s), ")
        check_node_output(node, ["gain", "moving_average"])


def test_slcan_on_a_pty_between_two_processes(example_hex, images):
    channel = unique("e2e-slcan")
    with (
        SlcanDevice(channel) as device,
        NodeThread([f"can://virtual/{channel}?role=node"], images) as node,
    ):
        assert device.url.startswith("can://slcan//dev/pts/")
        sent = hexmigrate(
            "send", example_hex["gain"], "--to", device.url, "--quiet", "--mode", "hex"
        )
        assert "module gain installed at 0x" in sent
        hexmigrate("send", example_hex["moving_average"], "--to", device.url, "--quiet")
        listing = hexmigrate("ls", "--to", device.url)
        assert [line.split()[0] for line in listing.splitlines()] == ["gain", "moving_average"]
        node.wait_running()
        node.stop()
    assert device.to_bus > 0 and device.to_host > 0
    assert_installed_and_ran(node, ["gain", "moving_average"])


# One process, the node in a thread of its own.


@pytest.mark.parametrize("mode", ["binary", "hex"])
def test_can_virtual_in_one_process(images, mode):
    channel = unique("e2e-virtual")
    with NodeThread([f"can://virtual/{channel}?role=node"], images) as node:
        with open_link(f"can://virtual/{channel}") as link:
            sender = Sender(link, mode)
            assert sender.ping().startswith("e2e: 0 module(s), ")
            for name in ("gain", "moving_average"):
                result = sender.send(images[name])
                assert (result.name, result.retransmissions) == (name, 0)
            assert [m.name for m in sender.modules()] == ["gain", "moving_average"]
            sender.remove("moving_average")
            assert [m.name for m in sender.modules()] == ["gain"]
        node.wait_running()
        node.stop()
    assert_installed_and_ran(node, ["gain"])


@pytest.mark.parametrize("mode", ["binary", "hex"])
def test_loop_one_port_shared_by_the_host_and_the_node(images, mode):
    """pyserial's loop:// is one port that hears itself: the host and the node are two
    stations on it, each hearing both sides' messages (as on an RS-485 line)."""
    line = SharedLine(open_link("loop://"))
    with line, NodeThread([line.station], images) as node, line.station() as host:
        sender = Sender(host, mode)
        for name in ("gain", "moving_average"):
            result = sender.send(images[name])
            assert (result.name, result.retransmissions) == (name, 0)
        assert [m.name for m in sender.modules()] == ["gain", "moving_average"]
        node.wait_running()
        node.stop()
    assert_installed_and_ran(node, ["gain", "moving_average"])


@pytest.mark.skipif(
    not Path("/sys/class/net/vcan0").exists(), reason="needs a SocketCAN interface vcan0"
)
def test_socketcan_in_one_process(images):
    with NodeThread(["can://socketcan/vcan0?role=node"], images) as node:
        with open_link("can://socketcan/vcan0") as link:
            assert Sender(link, "binary").send(images["gain"]).name == "gain"
        node.wait_running()
        node.stop()
    assert_installed_and_ran(node, ["gain"])


# Faults.


@pytest.mark.parametrize(("mode", "seeds"), [("binary", (9, 10)), ("hex", (15, 16))])
def test_one_percent_corruption_and_drops_both_ways(images, mode, seeds):
    channel = unique("e2e-faulty")
    node_url = f"faulty+can://virtual/{channel}?role=node#{FAULTS}&seed={seeds[0]}"
    with (
        NodeThread([node_url], images) as node,
        open_link(f"faulty+can://virtual/{channel}#{FAULTS}&seed={seeds[1]}") as link,
    ):
        node_end = node.link
        assert isinstance(link, FaultyLink) and isinstance(node_end, FaultyLink)
        sender = Sender(link, mode, timeout=0.3, retries=20)

        def injected() -> bool:
            """Faults went both ways, and both kinds of them (the seeds make it so soon)."""
            ends = [link.counts, node_end.counts]
            return (
                all(end.corrupted + end.dropped for end in ends)
                and any(end.corrupted for end in ends)
                and any(end.dropped for end in ends)
            )

        # Each round replaces gain at its commit; again until both directions saw faults.
        for _ in range(MAX_FAULTY_ROUNDS):
            assert sender.send(images["gain"]).name == "gain"
            if injected():
                break
        assert injected(), (link.counts, node_end.counts)
        node.wait_running()
        node.stop()
    assert_installed_and_ran(node, ["gain"])


@pytest.mark.parametrize(("mode", "cut_after"), [("binary", 800), ("hex", 2500)])
def test_a_cut_link_resumes_on_a_new_link_with_the_same_receiver(images, mode, cut_after):
    first, second = unique("e2e-cut"), unique("e2e-new")
    image = images["gain"]
    urls = [f"can://virtual/{first}?role=node", f"can://virtual/{second}?role=node"]
    with NodeThread(urls, images) as node:
        with (
            open_link(f"faulty+can://virtual/{first}#cut_after={cut_after}") as cut_link,
            pytest.raises(TransferInterrupted) as cut,
        ):
            Sender(cut_link, mode, window=1).send(image)
        assert 0 < cut.value.programmed < image.size
        assert node.installed == []
        node.advance()  # the node serves a new link, with the Receiver that holds the transfer
        with open_link(f"can://virtual/{second}") as link:
            resumed = Sender(link, mode).resume(image, cut.value.tid)
        assert resumed.name == "gain"
        node.wait_running()
        node.stop()
    assert_installed_and_ran(node, ["gain"])


def test_send_reconnects_and_resumes_by_itself(example_hex, images):
    """`hexmigrate send` over a link that dies after 700 bytes each time it is opened: it opens
    the link again and resumes where the node got to, until the module is installed."""
    with NodeProcess("tcp-listen://127.0.0.1:0", *GAIN_SET, "--show", "gain.y") as node:
        to = node.url
        flaky = f"faulty+{to}#cut_after=700"
        result = subprocess.run(
            [
                sys.executable,
                "-m",
                "hexmigrate",
                "send",
                str(example_hex["moving_average"]),
                "--to",
                flaky,
                "--quiet",
            ],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        assert result.returncode == 0, result.stderr
        assert "reconnecting (1/3)" in result.stderr
        assert "module moving_average installed" in result.stdout
        check_node_output(node, ["moving_average"])
        listing = hexmigrate("ls", "--to", to)
        assert f"{images['moving_average'].size} bytes" in listing


@pytest.mark.timeout(120)
def test_send_starts_again_when_the_node_restarted_and_lost_the_transfer(example_hex, tmp_path):
    """The node is killed mid-transfer and started again on its port (a power cut): `hexmigrate
    send` finds the transfer gone when it reconnects, says so, and sends the module anew."""
    module = example_hex["moving_average"]
    with NodeProcess("tcp-listen://127.0.0.1:0") as first:
        to = first.url
        command = [sys.executable, "-m", "hexmigrate", "send", str(module), "--quiet",
                   "--to", f"faulty+{to}#cut_after=700", "--reconnects", "20"]  # fmt: skip
        with Child.start("hexmigrate send", command, tmp_path / "send.log") as send:
            send.wait_for(r"reconnecting \(1/20\)", CLI_TIMEOUT)
            first.child.process.kill()  # before the first reconnection, a second from now
            first.child.process.wait()
            port = to.rpartition(":")[2]
            with NodeProcess(f"tcp-listen://127.0.0.1:{port}") as second:
                assert send.wait(CLI_TIMEOUT) == 0, send.lines()
                said = "\n".join(send.lines())
                assert "no longer holds transfer" in said
                assert "sending it again from the start" in said
                assert "module moving_average installed" in said
                assert hexmigrate("ls", "--to", second.url).startswith("moving_average ")


def test_a_listening_node_wires_a_module_each_time_it_arrives(example_hex):
    """`--native signal --wire signal.y=gain.x`: the wire is made once gain arrives, and gain
    then computes 2 x the ramp (the --show lines), not 0; made again when gain is sent again
    (the new gain replaces the old one and its connections), and when it is removed and sent
    once more."""
    wired = ("--native", "signal", "--set", "signal.amplitude=3", "--wire", "signal.y=gain.x")
    with NodeProcess("tcp-listen://127.0.0.1:0", *GAIN_SET, *wired, "--show", "gain.y") as node:
        to = node.url

        def send_and_see_gain_run() -> None:
            start = len(node.lines())
            hexmigrate("send", example_hex["gain"], "--to", to, "--quiet")
            index, _ = node.wait_for_line(r"^registered gain at 0x", start=start)
            shown = node.wait_for(r"gain\.y=([1-9]\d*)", start=index)  # 0 until the first cycles
            assert int(shown[1]) % 6 == 0  # 2 x k=2.0 x a ramp of +3 per cycle

        send_and_see_gain_run()
        send_and_see_gain_run()  # gain replaced
        hexmigrate("rm", "gain", "--to", to)
        node.wait_for(r"gain\.y=\?$", start=len(node.lines()))
        send_and_see_gain_run()  # gain back after it was removed
        assert not any("cannot wire" in line for line in node.lines()), node.lines()


def test_a_bitstream_configures_a_listening_node_s_fabric(tmp_path):
    """A hardware component migrates like a module: packed as extended HEX, sent, listed,
    removed; the node's reconfiguration port applies it to its crossbar."""
    bitstream = tmp_path / "slot2.hex"
    command = [sys.executable, "-m", "morphing_crossbar", "pack", "4", "2", "bypass"]
    subprocess.run([*command, "-o", str(bitstream)], check=True, timeout=CLI_TIMEOUT)
    with NodeProcess("tcp-listen://127.0.0.1:0", "--fpga", "4") as node:
        url = node.url
        node.wait_for(
            r"^fpga: a 4-slot Morphing Crossbar \(transaction-level model\) on the "
            r"reconfiguration port$"
        )
        sent = hexmigrate("send", bitstream, "--to", url)
        assert "module mx_slot2 installed at 0x40000200" in sent
        node.wait_for(r"^configured mx_slot2: slot 2 reconfigured in 25 fabric cycles$")
        assert "mx_slot2" in hexmigrate("ls", "--to", url)
        hexmigrate("rm", "mx_slot2", "--to", url)
        assert "mx_slot2" not in hexmigrate("ls", "--to", url)
