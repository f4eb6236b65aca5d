"""firmware_sim.cli: the ``firmware-sim`` command (``python -m firmware_sim``).

================  =========================================================================
``command``       the parser and the subcommands: run, listen, transfer, qemu, info
``qemu_command``  ``firmware-sim qemu``: the firmware in C on QEMU virt (firmware_sim.qemu)
``arguments``     its argument types, each with its range
``run_report``    what ``firmware-sim run`` reports, as text and as JSON
================  =========================================================================
"""
