"""Where gdb connects: a TCP listener on the address `--gdb HOST:PORT` names, one client at a
time, and the symbol lines that tell gdb where each module sits."""

from __future__ import annotations

import socket
from collections.abc import Callable, Iterator
from contextlib import closing, contextmanager

from firmware_sim.core.debug_port import DebugPort
from firmware_sim.gdb.packets import PacketConnection
from firmware_sim.gdb.stub import GdbStub


class GdbServer:
    """Listens for gdb on `host`:`port` (0: any free port) for the node's debug port `target`;
    `say` prints lines."""

    def __init__(self, target: DebugPort, host: str, port: int, say: Callable[[str], None]) -> None:
        self.target = target
        self.say = say
        self._listener = socket.create_server((host, port))
        self.host, self.port = self._listener.getsockname()[:2]
        self._stub: GdbStub | None = None
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
        """Wait for gdb, then hold the node halted until gdb resumes it."""
        connection, peer = self._listener.accept()
        self._attach(connection, peer)

    def poll(self) -> None:
        """Between jobs: take a gdb that connected (and halt for it), or see an interrupt."""
        if self._stub is not None and self._stub.attached:
            self._stub.poll()
            return
        self._listener.setblocking(False)
        try:
            connection, peer = self._listener.accept()
        except OSError:  # none waiting, or one that went away before it was taken
            return
        finally:
            self._listener.setblocking(True)
        connection.setblocking(True)
        self._attach(connection, peer)

    def close(self) -> None:
        """Stop listening and let the node run without gdb."""
        self.target.attach(None)
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
