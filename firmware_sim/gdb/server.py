"""Where gdb connects: a TCP listener on the address `--gdb HOST:PORT` names, one client at a
time, and the symbol lines that tell gdb where each module sits."""

from __future__ import annotations

import socket
from collections.abc import Callable, Iterator
from contextlib import closing, contextmanager

from firmware_sim.cpu import Cpu
from firmware_sim.gdb.packets import PacketConnection
from firmware_sim.gdb.stub import GdbStub
from firmware_sim.guest import GuestModule
from firmware_sim.node import Node


class GdbServer:
    """Listens for gdb on `host`:`port` (0: any free port) for `cpu`; `say` prints lines."""

    def __init__(self, cpu: Cpu, host: str, port: int, say: Callable[[str], None]) -> None:
        self.cpu = cpu
        self.say = say
        self._listener = socket.create_server((host, port))
        self.host, self.port = self._listener.getsockname()[:2]
        self._stub: GdbStub | None = None
        where = f"{self.host}:{self.port}"
        say(f"gdb: listening on {where} (in gdb: target remote {where})")

    def symbol_line(self, module: GuestModule, name: str) -> None:
        """Say the add-symbol-file line of a guest module, with its load offset."""
        if module.source is not None:
            offset = module.load_address - module.source.image.link_base
            self.say(f"gdb: add-symbol-file {module.source.path} -o 0x{offset:X}")
        else:
            offset = module.load_address - module.link_base
            self.say(
                f"gdb: add-symbol-file {name}.elf -o 0x{offset:X}  (module {name!r}: the node "
                "has not found its ELF; give the build's, with --elf)"
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
        self.cpu.attach_debugger(None)
        self._listener.close()

    def _attach(self, connection: socket.socket, peer: tuple) -> None:
        connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.say(f"gdb: connected from {peer[0]}:{peer[1]}; the node is halted")
        self._stub = GdbStub(self.cpu, PacketConnection(connection), self.say)
        self.cpu.attach_debugger(self._stub)
        self._stub.halt_outside()


@contextmanager
def debugging(
    node: Node, address: tuple[str, int] | None, say: Callable[[str], None], *, wait: bool
) -> Iterator[GdbServer | None]:
    """A GDB server for `node` while the block runs (None without an address): it says the
    symbol line of each module loaded, takes gdb between jobs, and with `wait` holds the node
    until gdb has connected and resumed it."""
    if address is None:
        yield None
        return
    with closing(GdbServer(node.cpu, *address, say)) as server:
        for name, module in node.modules.items():
            server.symbol_line(module.code, name)

        def between_jobs(_pbo: str, _time: float) -> None:
            server.poll()

        node.kernel.observe(between_jobs)
        try:
            if wait:
                server.wait()
            yield server
        finally:
            node.kernel.unobserve(between_jobs)
