"""A TCP port picked ahead for a process that will listen on it, where that process cannot take
a port of the system's choosing and tell it (a python-can-remote server) or must be told before
it starts (a node given its servo buses' URLs).

A port the system hands out for ``bind(HOST, 0)`` comes from its ephemeral range, the range it
also draws from for every outgoing connection and every other ``bind(0)`` on the machine: between
the probe and the listener's own bind, another program may take it ("Address already in use").
So the port is drawn below that range, where the system puts nothing by itself, at random (two
launchers picking at once rarely meet), probed free, and only as a last resort from the system.
"""

from __future__ import annotations

import random
import socket
from collections.abc import Collection
from pathlib import Path

from hexmigrate.errors import LinkError

EPHEMERAL_RANGE = Path("/proc/sys/net/ipv4/ip_local_port_range")
LOWEST = 10000
"""The lowest port drawn: below it sit the well-known and registered services' defaults."""
HIGHEST = 65535
DEFAULT_EPHEMERAL_START = 32768
"""Linux's default start of the ephemeral range, when the machine does not say its own."""
TRIES = 50


def ephemeral_start(path: Path) -> int:
    """The first port of the ephemeral range that `path` gives (Linux's
    ip_local_port_range), or Linux's default where the machine does not say."""
    try:
        return int(path.read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return DEFAULT_EPHEMERAL_START


def free_port(
    host: str = "127.0.0.1", purpose: str = "a listener", taken: Collection[int] = ()
) -> int:
    """A TCP port that nothing listens on now at `host`, below the ephemeral range when the
    range leaves room there, and none of `taken` (ports picked ahead for other listeners, not
    bound yet); LinkError naming `purpose` and the host when the host does not resolve or is not
    this machine's."""
    try:
        address = socket.getaddrinfo(host, 0, socket.AF_INET, socket.SOCK_STREAM)[0][4][0]
        below = min(ephemeral_start(EPHEMERAL_RANGE), HIGHEST + 1)
        for _ in range(TRIES if below > LOWEST else 0):
            port = random.randrange(LOWEST, below)
            if port not in taken and _binds(address, port):
                return port
        with socket.socket() as probe:  # the last resort: the system's choice
            probe.bind((address, 0))
            return int(probe.getsockname()[1])
    except OSError as error:
        raise LinkError(f"cannot start {purpose} on {host!r}: {error.strerror}") from None


def _binds(address: str, port: int) -> bool:
    """Whether `port` at `address` can be bound now (nothing listens there, none lingers)."""
    with socket.socket() as probe:
        try:
            probe.bind((address, port))
        except OSError:
            return False
        return True
