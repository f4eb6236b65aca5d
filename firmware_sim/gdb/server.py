"""Where gdb connects: a TCP listener on the address `--gdb HOST:PORT` names, one client at a
time, and the symbol lines that tell gdb where each module sits."""

from __future__ import annotations

import select
import socket
import time
from collections.abc import Callable, Iterator
from contextlib import closing, contextmanager

from firmware_sim.core.debug_port import DebugPort
from firmware_sim.errors import GdbServerError
from firmware_sim.gdb.packets import PacketConnection
from firmware_sim.gdb.stub import GdbStub

HELLO_TIMEOUT = 5.0
"""Seconds a client has from connecting to sending its first byte (gdb sends at once): the node
halts only for a client that speaks, so one that connects and says nothing cannot freeze it."""


class GdbServer:
    """Listens for gdb on `host`:`port` (0: any free port) for the node's debug port `target`;
    `say` prints lines."""

    def __init__(self, target: DebugPort, host: str, port: int, say: Callable[[str], None]) -> None:
        self.target = target
        self.say = say
        try:
            self._listener = socket.create_server((host, port))
        except OSError as error:  # a host that is none of this machine's, a port in use
            raise GdbServerError(
                f"gdb server at {host}:{port}: expected an address this host can listen on, "
                f"got {error.strerror or error}"
            ) from None
        self.host, self.port = self._listener.getsockname()[:2]
        self._stub: GdbStub | None = None
        self._pending: tuple[socket.socket, tuple, float] | None = None
        """A client that connected and has not spoken yet, its peer and its hello deadline."""
        where = f"{self.host}:{self.port}"
        say(f"gdb: listening on {where} (in gdb: target remote {where})")

    def symbol_line(self, name: str) -> None:
        """Say the add-symbol-file line of guest module `name`, with its load offset."""
        symbols = self.target.symbol_file(name)
        if symbols.elf is not None:
            self.say(f"gdb: add-symbol-file {symbols.elf} -o 0x{symbols.offset:X}")
            # the SDK's DWARF names sources relative to the build folder (./gain.c)
            self.say(f"gdb: directory {symbols.elf.parent}")
        else:
            self.say(
                f"gdb: add-symbol-file {name}.elf -o 0x{symbols.offset:X}  (module {name!r}: "
                "the node has not found its ELF; give the build's, with --elf)"
            )

    def wait(self) -> None:
        """Wait for gdb, then hold the node halted until gdb resumes it; a client that says
        nothing within HELLO_TIMEOUT is let go and the wait goes on."""
        while True:
            connection, peer = self._listener.accept()
            if select.select([connection], [], [], HELLO_TIMEOUT)[0]:
                self._attach(connection, peer)
                return
            self._let_go(connection, peer)

    def poll(self) -> None:
        """Between jobs: take a gdb that connected and spoke (and halt for it), or see an
        interrupt. The node runs on while a client that connected has not spoken."""
        if self._stub is not None and self._stub.attached:
            self._stub.poll()
            return
        if self._pending is None:
            self._pending = self._accepted()
        if self._pending is not None:
            connection, peer, due = self._pending
            if select.select([connection], [], [], 0)[0]:
                self._pending = None
                self._attach(connection, peer)
            elif time.monotonic() > due:
                self._pending = None
                self._let_go(connection, peer)

    def _accepted(self) -> tuple[socket.socket, tuple, float] | None:
        """A client waiting to be taken, with its hello deadline; None when there is none."""
        self._listener.setblocking(False)
        try:
            connection, peer = self._listener.accept()
        except OSError:  # none waiting, or one that went away before it was taken
            return None
        finally:
            self._listener.setblocking(True)
        connection.setblocking(True)
        return connection, peer, time.monotonic() + HELLO_TIMEOUT

    def _let_go(self, connection: socket.socket, peer: tuple) -> None:
        connection.close()
        self.say(f"gdb: {peer[0]}:{peer[1]} said nothing in {HELLO_TIMEOUT:g} s; let go")

    def close(self) -> None:
        """Stop listening and let the node run without gdb."""
        self.target.attach(None)
        if self._pending is not None:
            self._pending[0].close()
        self._listener.close()

    def _attach(self, connection: socket.socket, peer: tuple) -> None:
        connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.say(f"gdb: connected from {peer[0]}:{peer[1]}; the node is halted")
        self._stub = GdbStub(self.target, PacketConnection(connection), self.say)
        self.target.attach(self._stub)
        self._stub.halt_outside()


@contextmanager
def debugging(
    target: DebugPort, address: tuple[str, int] | None, say: Callable[[str], None], *, wait: bool
) -> Iterator[GdbServer | None]:
    """A GDB server for the node of debug port `target` while the block runs (None without an
    address): it says the symbol line of each module loaded, takes gdb between jobs, and with
    `wait` holds the node until gdb has connected and resumed it."""
    if address is None:
        yield None
        return
    with closing(GdbServer(target, *address, say)) as server:
        for name in target.modules():
            server.symbol_line(name)
        target.between_jobs(server.poll)
        try:
            if wait:
                server.wait()
            yield server
        finally:
            target.between_jobs(None)
