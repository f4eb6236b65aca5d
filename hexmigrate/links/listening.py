"""Where a listening node listens: its end of the link, and the line that says where it is.

The line is the node's first line of output, so that a script can read it: ``listening on
/dev/pts/N ...`` for ``pty`` (a new pty pair), ``listening on tcp-listen://127.0.0.1:PORT ...``
with the port the system picked for ``tcp-listen://127.0.0.1:0``, both followed by the command
that connects.
"""

from __future__ import annotations

import re
from collections.abc import Callable

from hexmigrate.links import open_link
from hexmigrate.links.base import Link
from hexmigrate.links.serial import PtyPair
from hexmigrate.links.tcp import TcpListenLink

PTY = "pty"
CONNECT_URL = re.compile(r"\(connect with: hexmigrate send FILE\.hex --to (\S+)\)$")
"""The end of the listening line: the URL a host opens to reach the node (a pty's path, a
``tcp-listen://`` node's ``socket://`` URL), which launchers read."""


def node_side(url: str) -> str:
    """`url` with ``role=node`` on a CAN link (bare or inside ``faulty+``) that names no role:
    a listening node takes the node's identifiers, as a user expects without saying so."""
    prefix = "faulty+" if url.startswith("faulty+") else ""
    inner, hash_, fragment = url[len(prefix) :].partition("#")
    if not inner.startswith("can://") or "role=" in inner:
        return url
    joiner = "&" if "?" in inner else "?"
    return f"{prefix}{inner}{joiner}role=node{hash_}{fragment}"


def open_listening(url: str, say: Callable[[str], None]) -> Link:
    """The node's end of the link at `url` (``pty`` opens a new pty pair); says where it is."""
    if url == PTY:
        pair = PtyPair.open()
        say(f"listening on {pair.path} (connect with: hexmigrate send FILE.hex --to {pair.path})")
        return pair.link
    link = open_link(node_side(url))
    server = tcp_server(link)
    if server is None:
        say(f"listening on {url}")
    else:  # say the port the system picked for port 0, also through a faulty+ wrapper
        shown = url.replace(server.url, server.bound_url, 1)
        say(
            f"listening on {shown} (connect with: hexmigrate send FILE.hex --to "
            f"{server.connect_url})"
        )
    return link


def tcp_server(link: Link) -> TcpListenLink | None:
    """The ``tcp-listen://`` link `link` is or wraps (faulty+...), if any."""
    current: object = link
    while current is not None:
        if isinstance(current, TcpListenLink):
            return current
        current = getattr(current, "inner", None)
    return None
