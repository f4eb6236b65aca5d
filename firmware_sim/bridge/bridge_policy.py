"""Which bridges a node sets up when a host asks (`ImportPort`, `ExportPort`): the transport a
bridge needs and nothing else, on the hosts the node's operator allowed, and a bounded number.

An import listens on ``tcp-listen://HOST:PORT``, an export connects to ``socket://HOST:PORT``
(with the bridge's key, value_message.py): no pty, serial port, CAN bus or ``loop://`` a request
could make the node open. HOST must be one the operator allowed: a loopback address, the host
the node listens on, or a ``--bridge-host`` (a request must not make a node bind, or
connect to, any address the requester chose). A node holds at most MAX_BRIDGES halves.
"""

from __future__ import annotations

import ipaddress
from dataclasses import dataclass

from firmware_sim.errors import BridgeError

MAX_BRIDGES = 32
"""Bridge halves (imports and exports) a node holds at once."""
LOOPBACK = "the loopback addresses (127.0.0.0/8, ::1, localhost)"
"""Hosts a bridge may always use: this machine."""
IMPORT_SCHEME, EXPORT_SCHEME = "tcp-listen://", "socket://"


@dataclass(frozen=True)
class BridgePolicy:
    """The hosts bridges may use besides the loopback ones (`hosts`)."""

    hosts: tuple[str, ...] = ()

    def check(self, number: int, url: str, exporting: bool, held: int) -> None:
        """Refuse (BridgeError) bridge `number`'s `url` unless it is the transport the half
        needs on an allowed host, and a new half when the node holds `held` already."""
        if held >= MAX_BRIDGES:
            raise BridgeError(
                f"bridge {number}: expected at most {MAX_BRIDGES} bridges on a node, got "
                f"{held} already (take one down first)"
            )
        scheme = EXPORT_SCHEME if exporting else IMPORT_SCHEME
        where = url.partition("#")[0]
        host = where.removeprefix(scheme).rpartition(":")[0].removeprefix("[").removesuffix("]")
        if not where.startswith(scheme) or not host:
            raise BridgeError(f"bridge {number}: expected {scheme}HOST:PORT, got {where[:80]!r}")
        if not (_loopback(host) or host in self.hosts):
            allowed = ", ".join([LOOPBACK, *self.hosts])
            raise BridgeError(
                f"bridge {number}: expected a host the node allows bridges on ({allowed}; "
                f"firmware-sim listen --bridge-host HOST), got {host[:80]!r}"
            )


def _loopback(host: str) -> bool:
    """Whether `host` is this machine's loopback: any 127.0.0.0/8 address, ::1, localhost."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False
