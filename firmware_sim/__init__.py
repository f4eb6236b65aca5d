"""firmware_sim: the emulated node, in rooms whose names say what each is.

Each room is a subpackage; a room imports only the rooms above it in this list (the layer test,
tests/test_layers.py, enforces it) and every room may raise the one error tree:

============  =====================================================================================
``errors``    the exception tree under FirmwareSimError, shared by every room
``core``      one node in one process: the RV32IM CPU on Unicorn, memory map, SRAM, flash and its
              directory, the loader, guest modules as PBOs, natives, power, trust, the node; no
              links, no argparse. Its debug port is the one way in for a debugger.
``wires``     the wire timing models: bytes and frames on a UART or a CAN bus, and a whole
              transfer into a node in virtual time
``bridge``    ports carried between robots, timed on a modelled wire: both nodes in one process,
              or one in each process over a link
``gdb``       the GDB remote-protocol stub; it meets the core only through its debug port
``serving``   a node on a link (``firmware-sim listen``): serving the transfer protocol and node
              control, the PBOs that arrive, bridges to other node processes, lock-step time
``cli``       the ``firmware-sim`` command (``python -m firmware_sim``): run, listen, transfer,
              info
============  =====================================================================================

Beside it, importing none of it: the module SDK (`module_sdk`, the C side of a module) and the
servo emulators (`servo_emulators`).
"""
