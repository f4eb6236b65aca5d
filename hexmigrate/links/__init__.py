"""Transports for module transfers, opened by URL: ``open_link(url)``, one module per scheme.

================================  ========================================  ================
URL                               what                                      module
================================  ========================================  ================
``serial:///dev/ttyUSB0``         a serial device, ``?baudrate=`` (115200)  `serial`
``/dev/pts/5``                    a bare device path (a pty's far end)      `serial`
``loop://``                       pyserial's loopback                       `serial`
``socket://HOST:PORT``            a raw TCP byte stream (a client)          `tcp_client`
``tcp-listen://HOST:PORT``        its server end, for a node, bound to      `tcp`
                                  HOST only; port 0: any
``can://virtual/CHANNEL``         python-can's in-process bus, ISO-TP       `can`
``can://remote/HOST:P/CHANNEL``   a python-can-remote server, ISO-TP        `can`
``can://slcan//dev/DEVICE``       an SLCAN adapter, ISO-TP                  `can`
``can://socketcan/vcan0``         Linux SocketCAN, ISO-TP                   `can`
``faulty+INNER#FAULTS``           any of the above with injected faults     `faulty`
================================  ========================================  ================

HOST is an IPv4 address (``127.0.0.2``), an IPv6 address in brackets (``[::1]``) or a host name,
so that nodes, hosts and CAN servers may sit on different machines (python-can-remote's server
listens on IPv4 only).

Each module documents its grammar at its top. `framing` says how messages travel on a byte
stream; `tcp` is the listening end a ``socket://`` client (`tcp_client`) connects to, for a node
that serves one host after another; `remote_server` runs a python-can-remote server that puts
processes, on one machine or several, on one CAN channel, and `slcan_device` makes a node's CAN
controller look like an SLCAN adapter on a pty. Scheme modules are imported when first used, so
a machine without python-can can still use serial links.
"""

from __future__ import annotations

import importlib

from commandline.extras import missing_extra
from hexmigrate.errors import LinkError, LinkUrlError
from hexmigrate.links.base import Link, LinkBase, is_text

__all__ = ["Link", "LinkBase", "is_text", "open_link"]

_SCHEMES: dict[str, tuple[str, str]] = {
    "": ("serial", "pyserial"),
    "serial": ("serial", "pyserial"),
    "loop": ("serial", "pyserial"),
    "socket": ("tcp_client", "nothing beyond Python's standard library"),
    "tcp-listen": ("tcp", "nothing beyond Python's standard library"),
    "can": ("can", "python-can, can-isotp and (for can://remote) python-can-remote"),
    "faulty": ("faulty", "nothing more than its inner link"),
}
"""Scheme -> (module in this package, what it needs installed). The empty scheme is a bare
device path."""

_FORMS = (
    "serial:///dev/DEVICE, /dev/DEVICE, loop://, socket://HOST:PORT, tcp-listen://HOST:PORT, "
    "can://... or faulty+URL"
)
_KNOWN = "serial, loop, socket, tcp-listen, can or faulty+"


def open_link(url: str, **options: object) -> LinkBase:
    """The link `url` names, open. `options` are the scheme's URL parameters given as keywords
    (``open_link("can://virtual/x", role="node")``); they override the URL's own.

    Raises LinkUrlError for a malformed URL, LinkError when the transport cannot be opened.
    """
    scheme = _scheme(url)
    if scheme not in _SCHEMES:
        raise LinkUrlError(
            f"bad link URL {url!r}: expected a scheme among {_KNOWN}, got {scheme!r}; "
            f"the form is {_FORMS}{_tcp_hint(url)}"
        )
    module_name, needs = _SCHEMES[scheme]
    try:
        module = importlib.import_module(f"{__name__}.{module_name}")
    except ImportError as error:
        what = f"the {scheme}: scheme" if scheme else "a device path"
        extra = missing_extra(error) if isinstance(error, ModuleNotFoundError) else None
        reason = f"{what}: {extra}" if extra else f"{what} needs {needs}: {error}"
        raise LinkError(f"cannot open {url}: {reason}") from error
    link: LinkBase = module.open_url(url, **options)
    return link


def _tcp_hint(url: str) -> str:
    """For a URL that means TCP without saying which end (``HOST:PORT``, ``tcp://HOST:PORT``):
    the two URLs it may have meant."""
    address = url.removeprefix("tcp://")
    host, colon, port = address.rpartition(":")
    if not (colon and host and port.isdigit() and "/" not in address):
        return ""
    return (
        f" (for TCP: socket://{address} reaches a node that listens there, "
        f"tcp-listen://{address} listens there for hosts)"
    )


def _scheme(url: str) -> str:
    """The scheme that picks the module: ``faulty`` for ``faulty+...``, "" for a device path."""
    if url.startswith("/"):
        return ""
    head, colon, _ = url.partition(":")
    if head.startswith("faulty+"):
        return "faulty"
    if not colon or not head:
        raise LinkUrlError(
            f"bad link URL {url!r}: expected SCHEME:... or an absolute device path, got no "
            f"scheme; the form is {_FORMS}"
        )
    return head
