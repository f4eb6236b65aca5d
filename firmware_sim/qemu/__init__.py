"""firmware_sim.qemu: the node firmware in C (firmware/) on QEMU's ``virt`` machine, on a pty.

==================  =====================================================================
``errors``          `QemuError`, what goes wrong starting a QEMU node
``firmware_build``  the firmware's ELF: built with the project's Makefile when missing
``flash_file``      the CFI flash's backing file: 32 MiB, created erased (0xFF)
``machine``         `QemuNode`: QEMU started with the UART on a pty, handshake, stop, kill
==================  =====================================================================

`firmware-sim qemu` (firmware_sim.cli) runs one and prints the same ``listening on ...`` line
`firmware-sim listen --listen pty` prints; docs/firmware.md describes the firmware.
"""
