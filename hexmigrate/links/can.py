"""CAN links: each message is one ISO-TP (ISO 15765-2) transfer, through python-can and can-isotp.

URL grammar::

    can://virtual/CHANNEL[?PARAMETERS]            python-can's in-process bus, any channel name
    can://remote/HOST:PORT/CHANNEL[?PARAMETERS]   a python-can-remote server (see remote_server)
                                                  serving CHANNEL, for two processes
    can://slcan/DEVICE[?PARAMETERS]               an SLCAN (Lawicel ASCII) adapter; DEVICE is an
                                                  absolute path, hence two slashes:
                                                  can://slcan//dev/ttyACM0 (append @BAUD to the
                                                  path for a UART adapter: /dev/ttyS1@921600)
    can://socketcan/INTERFACE[?PARAMETERS]        Linux SocketCAN, for example can://socketcan/vcan0

Parameters (a number may be decimal or 0x-hexadecimal):

    role=host|node   which default ids: host sends on 0x7E0 and listens on 0x7E8, node the
                     reverse (default host)
    txid=ID rxid=ID  11-bit ids (0..0x7FF) that override the role's defaults
    bitrate=N        bit/s (default 500000); an SLCAN adapter takes 10000, 20000, 50000,
                     100000, 125000, 250000, 500000, 750000, 1000000 or 83300
    stmin=N          the gap between consecutive frames this side asks of a sender, in its flow
                     control frames: 0..127 ms, or 0xF1..0xF9 for 100..900 us (default 0, as
                     fast as the bus goes)
    blocksize=N      consecutive frames this side lets a sender send between its flow control
                     frames, 0 for all of them (default 0)
    padding=off|N    fill every frame to 8 bytes with byte N (default 0xCC) or send short
                     frames (off); both ends should agree
    settle=S         seconds to wait after opening an SLCAN adapter that resets on open, as
                     Arduino-based ones do (default 0)

Classic CAN frames carry 8 data bytes. ISO-TP puts 7 message bytes in a single frame, 6 in the
first frame of a longer transfer (2 if the message exceeds 4095 bytes, which needs the 32-bit
length of ISO 15765-2:2016), and 7 in each consecutive frame; the receiver answers the first frame
(and each block, if blocksize > 0) with a flow control frame.

`open_bus(url)` opens the python-can bus of a URL alone, for a program that speaks CAN itself
(the servo bus, the servo emulator): the one way every bus of a ``can://`` URL opens.
"""

from __future__ import annotations

import http.client
import logging
import math
import re
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import can
import isotp
from can_remote.websocket import WebsocketClosed

from hexmigrate.errors import LinkError
from hexmigrate.links.base import MAX_MESSAGE_SIZE, LinkBase
from hexmigrate.links.can_defaults import DEFAULT_BITRATE, DEFAULT_PADDING, HOST_IDS
from hexmigrate.links.url import (
    choice,
    host_and_port,
    integer,
    parse_parameters,
    real,
    split_url,
    url_error,
)

logger = logging.getLogger(__name__)
ISOTP_LOGGER = f"{__name__}.isotp"
"""Where can-isotp logs (its `logger_name`). It logs each transport error as a warning after
handing it to `CanLink._on_transport_error`, which counts it: a send nobody takes would print
"Reception of FlowControl timed out" on the user's terminal beside the link's own line for the
same loss, which says which link and how many bytes. Its warnings are kept below the level a
terminal shows; its errors are not."""
logging.getLogger(ISOTP_LOGGER).setLevel(logging.ERROR)

FORM = (
    "can://virtual/CHANNEL, can://remote/HOST:PORT/CHANNEL, can://slcan//dev/DEVICE or "
    "can://socketcan/INTERFACE, with optional ?role=host|node&txid=ID&rxid=ID&bitrate=N"
    "&stmin=N&blocksize=N&padding=off|N&settle=S"
)
SLCAN_BITRATES = (10000, 20000, 50000, 100000, 125000, 250000, 500000, 750000, 1000000, 83300)
NOTIFIER_TIMEOUT = 0.05
"""How long python-can's reader waits per call: the bound on the time `close` takes."""
FRAME_TIMEOUT = 1.0
"""ISO-TP's N_Bs and N_Cr: how long a sender waits for a flow control frame, and a receiver for
the next consecutive frame, before it gives the transfer up."""
RETRY_PAUSE = 0.02
"""Between two tries to reach a bus's server that refused the connection (seconds)."""
OPEN_TIMEOUT = 10.0
"""Seconds opening a bus may take (a remote server's handshake) before it is given up."""
_BROKEN_SERVER = (
    AssertionError,
    AttributeError,
    KeyError,
    TypeError,
    http.client.HTTPException,
    WebsocketClosed,
)
"""What python-can-remote's client raises when the server at a ``can://remote`` URL does not
speak its protocol (its handshake asserts; a missing header or field)."""


def _stmin(text: str) -> int:
    """ISO-TP's STmin byte: 0..0x7F milliseconds or 0xF1..0xF9 for 100..900 microseconds."""
    value: int = integer(0, 0xF9, show_hex=True)(text)
    if 0x7F < value < 0xF1:
        raise ValueError(f"expected 0x0..0x7f or 0xf1..0xf9, got {value:#x}")
    return value


def _padding(text: str) -> int | None:
    """``off`` or the byte that fills frames to 8 bytes."""
    if text == "off":
        return None
    try:
        value: int = integer(0, 0xFF, show_hex=True)(text)
    except ValueError:
        raise ValueError(f"expected off or a byte 0x0..0xff, got {text!r}") from None
    return value


_PARAMETERS = {
    "role": choice("host", "node"),
    "txid": integer(0, 0x7FF, show_hex=True),
    "rxid": integer(0, 0x7FF, show_hex=True),
    "bitrate": integer(1, 8_000_000),
    "stmin": _stmin,
    "blocksize": integer(0, 255),
    "padding": _padding,
    "settle": real(0.0, 10.0),
}


@dataclass(frozen=True)
class CanSettings:
    """A parsed ``can://`` URL: where the bus is and how ISO-TP runs on it."""

    interface: str
    channel: str
    txid: int
    rxid: int
    bitrate: int
    stmin: int
    blocksize: int
    padding: int | None
    settle: float

    def isotp_params(self) -> dict[str, Any]:
        """can-isotp's parameters: classic 8-byte frames, blocking sends, large messages."""
        return {
            "stmin": self.stmin,
            "blocksize": self.blocksize,
            "tx_data_length": 8,
            "tx_padding": self.padding,
            "max_frame_size": MAX_MESSAGE_SIZE,
            "rx_flowcontrol_timeout": int(FRAME_TIMEOUT * 1000),
            "rx_consecutive_frame_timeout": int(FRAME_TIMEOUT * 1000),
            "blocking_send": True,
            "logger_name": ISOTP_LOGGER,
        }

    def bus_config(self) -> dict[str, Any]:
        """python-can's `Bus` arguments; the configuration files and CAN_* variables are ignored,
        so that the URL alone says what opens."""
        config: dict[str, Any] = {"interface": self.interface, "ignore_config": True}
        if self.interface == "remote":
            config["channel"] = f"ws://{self.channel.partition('/')[0]}/"
            config["bitrate"] = self.bitrate
        elif self.interface == "slcan":
            config.update(channel=self.channel, bitrate=self.bitrate)
            config["sleep_after_open"] = self.settle
        else:
            config["channel"] = self.channel
        return config


def parse_url(url: str, **options: object) -> CanSettings:
    """The settings a ``can://`` URL stands for; LinkUrlError with the expected form if bad."""
    parts = split_url(url, FORM)
    if parts.scheme != "can":
        raise url_error(url, f"expected the can scheme, got {parts.scheme!r}", FORM)
    if parts.fragment:
        raise url_error(url, f"expected no #fragment, got '#{parts.fragment}'", FORM)
    channel = _channel(url, parts.netloc, parts.path)
    parameters = parse_parameters(url, parts.query, _PARAMETERS, FORM, options)
    default_tx, default_rx = (
        HOST_IDS if parameters.get("role", "host") == "host" else HOST_IDS[::-1]
    )
    settings = CanSettings(
        interface=parts.netloc,
        channel=channel,
        txid=parameters.get("txid", default_tx),
        rxid=parameters.get("rxid", default_rx),
        bitrate=parameters.get("bitrate", DEFAULT_BITRATE),
        stmin=parameters.get("stmin", 0),
        blocksize=parameters.get("blocksize", 0),
        padding=parameters.get("padding", DEFAULT_PADDING),
        settle=parameters.get("settle", 0.0),
    )
    _check_settings(url, settings)
    return settings


def _channel(url: str, interface: str, path: str) -> str:
    """The channel part of the path, checked against what `interface` expects."""
    channel = path[1:]
    if interface == "remote":
        remote_address(url, channel)
        return channel
    if interface in ("virtual", "socketcan"):
        if channel and "/" not in channel and channel.isprintable():
            return channel
        raise url_error(url, f"expected a name after can://{interface}/, got {channel!r}", FORM)
    if interface == "slcan":
        if channel.startswith("/"):
            return channel
        raise url_error(url, f"expected a device path after can://slcan/, got {channel!r}", FORM)
    raise url_error(url, f"expected virtual, remote, slcan or socketcan, got {interface!r}", FORM)


def remote_address(url: str, channel: str, lowest_port: int = 1) -> tuple[str, int, str]:
    """``HOST:PORT/CHANNEL`` of a ``can://remote`` `url` as (host, port, channel), checked:
    PORT from `lowest_port` (0: any free one, where a server is to listen), a channel name of
    printable characters; LinkUrlError naming what is wrong."""
    address, _, name = channel.partition("/")
    host, _, port = address.rpartition(":")
    form = "can://remote/HOST:PORT/CHANNEL such as can://remote/127.0.0.1:54701/node0"
    if not host or not name or "/" in name or not name.isprintable():
        raise url_error(
            url, f"expected HOST:PORT/CHANNEL after can://remote/, got {channel!r}", form
        )
    _, number = host_and_port(url, host, port, form, lowest_port)
    return host, number, name


def _check_settings(url: str, settings: CanSettings) -> None:
    if settings.txid == settings.rxid:
        problem = f"expected different txid and rxid, got {settings.txid:#x} for both"
        raise url_error(url, problem, FORM)
    if settings.interface == "slcan" and settings.bitrate not in SLCAN_BITRATES:
        choices = ", ".join(map(str, SLCAN_BITRATES))
        problem = f"parameter bitrate: expected {choices} for SLCAN, got {settings.bitrate}"
        raise url_error(url, problem, FORM)


def open_url(url: str, **options: object) -> CanLink:
    """A CAN link for a ``can://`` URL (see the module's grammar)."""
    return CanLink(url, parse_url(url, **options))


class CanLink(LinkBase):
    """One ISO-TP connection (a txid/rxid pair) on a python-can bus.

    The ISO-TP layer runs in can-isotp's threads, fed by a python-can Notifier, so frames are
    answered (flow control) while the application is busy, as a CAN controller's driver would.
    `send` returns once the transfer is complete. A transfer that fails (no flow control from a
    peer, a timeout) is lost, as bytes sent down an unplugged serial cable are: it is counted in
    `lost`, and the protocol above notices by its own timeouts. A bus that fails (the remote
    server gone, the adapter unplugged) fails the link: LinkError on the next call.

    The layer is can-isotp's `TransportLayer` with the reading half of its
    `NotifierBasedCanStack` (a BufferedReader on the Notifier) and a transmit function of its own:
    the stock one lets a bus error escape into, and silently end, can-isotp's thread.
    """

    def __init__(self, url: str, settings: CanSettings) -> None:
        super().__init__(url)
        self.settings = settings
        self.lost = 0
        """Messages whose transfer failed and that the peer therefore never got."""
        self.transport_errors = 0
        """ISO-TP errors seen: unexpected frames, timeouts, overflows."""
        self._failure: LinkError | None = None
        self._bus = _open_bus(url, settings)
        self._reader = can.BufferedReader()
        self._notifier = can.Notifier(self._bus, [self._reader], timeout=NOTIFIER_TIMEOUT)
        self._notifier.add_listener(_BusWatch(self._notifier, self._on_bus_error))
        self._stack = isotp.TransportLayer(
            rxfn=self._read_frame,
            txfn=self._write_frame,
            address=isotp.Address(
                isotp.AddressingMode.Normal_11bits, txid=settings.txid, rxid=settings.rxid
            ),
            error_handler=self._on_transport_error,
            params=settings.isotp_params(),
        )
        self._stack.start()

    def _send(self, message: bytes) -> None:
        self._raise_if_failed()
        try:
            self._stack.send(message, send_timeout=_send_budget(len(message)))
        except isotp.BlockingSendFailure as error:
            self._stack.stop_sending()
            self.lost += 1
            logger.warning("%s: message of %d bytes lost: %s", self.url, len(message), error)
        self._raise_if_failed()

    def _receive(self, timeout: float) -> bytes | None:
        if self._failure is not None:
            message = self._stack.recv(block=False)
            if message is None:
                raise self._failure
        else:
            message = self._stack.recv(block=True, timeout=timeout)
        return None if message is None else bytes(message)

    def _close(self) -> None:
        self._stack.stop()
        self._notifier.stop(timeout=10 * NOTIFIER_TIMEOUT + 1.0)
        shut_down(self._bus)

    def _read_frame(self, timeout: float) -> isotp.CanMessage | None:
        """can-isotp's receive function: the next data frame from the Notifier, if any."""
        message = self._reader.get_message(timeout)
        if message is None or message.is_error_frame or message.is_remote_frame:
            return None
        return isotp.CanMessage(
            arbitration_id=message.arbitration_id,
            data=bytes(message.data),
            extended_id=message.is_extended_id,
        )

    def _write_frame(self, frame: isotp.CanMessage) -> None:
        """can-isotp's transmit function: one frame on the bus, a bus error kept for the caller."""
        if self._failure is not None:
            return
        message = can.Message(
            arbitration_id=frame.arbitration_id, data=frame.data, is_extended_id=False
        )
        try:
            self._bus.send(message)
        except (can.CanError, OSError) as error:
            self._on_bus_error(error)

    def _on_bus_error(self, error: Exception) -> None:
        if self._failure is None:
            self._failure = LinkError(f"{self.url}: the CAN bus failed: {error}")

    def _on_transport_error(self, error: Exception) -> None:
        self.transport_errors += 1
        logger.debug("%s: ISO-TP: %s", self.url, error)

    def _raise_if_failed(self) -> None:
        if self._failure is not None:
            raise self._failure


class _BusWatch(can.Listener):
    """The Notifier's error listener. A dead bus raises on every read and python-can's reader
    would go on calling it, so the first error stops the Notifier and fails the link."""

    def __init__(self, notifier: can.Notifier, on_error: Callable[[Exception], None]) -> None:
        self._notifier = notifier
        self._on_error = on_error

    def on_message_received(self, msg: can.Message) -> None:
        """Frames are the BufferedReader's business."""

    def on_error(self, exc: Exception) -> None:
        self._on_error(exc)
        self._notifier.stop(timeout=0)


def open_bus(url: str, wait: float = 0.0) -> can.BusABC:
    """python-can's bus for a ``can://`` URL, for a program that speaks CAN itself (the URL's
    ISO-TP parameters do not apply); the caller shuts it down. LinkUrlError for a malformed URL;
    LinkError naming the URL when the bus does not open: no device, no driver, no server, a
    server that does not speak python-can-remote or serves another channel. A server that
    refuses the connection is tried again for `wait` seconds: a process started at the same time
    as the one that serves its bus may be ready first. One that accepts the connection and says
    nothing for OPEN_TIMEOUT seconds is given up (python-can-remote's client sets no timeout of
    its own: its opening runs on a thread the caller does not wait for past that)."""
    return _open_bus(url, parse_url(url), wait)


def _open_bus(url: str, settings: CanSettings, wait: float = 0.0) -> can.BusABC:
    """`open_bus` for settings already parsed: a link's, its options included."""
    deadline = time.monotonic() + wait
    while True:
        try:
            bus = _bus_within(url, settings, OPEN_TIMEOUT)
            break
        except ConnectionRefusedError as error:
            if not time.monotonic() < deadline:  # NaN waits no more than 0 s
                raise LinkError(f"cannot open {url}: {error}") from error
            time.sleep(RETRY_PAUSE)
        except (can.CanError, OSError, ValueError, ImportError) as error:
            raise LinkError(f"cannot open {url}: {error}") from error
        except _BROKEN_SERVER as error:
            raise LinkError(
                f"cannot open {url}: expected a python-can-remote server, got {error!r}"
            ) from error
    if settings.interface == "remote":
        _check_remote_channel(url, bus, settings.channel.partition("/")[2])
    return bus


def _bus_within(url: str, settings: CanSettings, timeout: float) -> can.BusABC:
    """python-can's bus for `settings`, made on a thread of its own and waited for `timeout`
    seconds at most: a remote server that accepts the connection and never answers its
    handshake would hold the caller forever. Its errors are raised here; past the timeout a
    LinkError says so, and the thread is left to end with its connection (a bus it still
    opens then is shut down, not leaked)."""
    made: list[can.BusABC] = []
    failed: list[BaseException] = []
    given_up = threading.Event()
    lock = threading.Lock()

    def make() -> None:
        try:
            bus = can.Bus(**settings.bus_config())
        except BaseException as error:  # raised again on the caller's thread
            failed.append(error)
            return
        with lock:
            if not given_up.is_set():
                made.append(bus)
                return
        shut_down(bus)  # it answered after all, but nobody waits for it any more

    opening = threading.Thread(target=make, name=f"open {url}", daemon=True)
    opening.start()
    opening.join(timeout)
    with lock:
        if not made:
            given_up.set()
    if failed:
        raise failed[0]
    if not made:
        raise LinkError(f"cannot open {url}: the other end said nothing for {timeout:g} s")
    return made[0]


def shut_down(bus: can.BusABC) -> None:
    """Shut `bus` down even if its connection is already gone: python-can-remote's shutdown then
    raises before it closes its socket and marks the bus shut down (its finalizer would raise
    again), so both are done here."""
    try:
        bus.shutdown()
    except (can.CanError, OSError) as error:
        logger.debug("shutting down %s: %s", bus.channel_info, error)
        can.BusABC.shutdown(bus)
        connection = getattr(bus, "socket", None)
        if isinstance(connection, socket.socket):
            connection.close()


def _check_remote_channel(url: str, bus: can.BusABC, channel: str) -> None:
    """Refuse a server of another channel: the server, not the client, picks the channel, and
    talking to the wrong one would only show as timeouts. The server's description of its bus
    (``Virtual bus channel two words on ws://...``) names the channel between spaces or
    quotes."""
    if not re.search(rf"(?<![^\s'\"]){re.escape(channel)}(?![^\s'\"])", bus.channel_info):
        shut_down(bus)
        raise LinkError(
            f"cannot open {url}: expected a server of channel {channel!r}, got {bus.channel_info!r}"
        )


def _send_budget(size: int) -> float:
    """How long a transfer of `size` bytes may take before it counts as lost: generous for a
    slow adapter (1 ms a frame) and for a peer that answers flow control late."""
    return 2 * FRAME_TIMEOUT + 0.001 * math.ceil(size / 7)
