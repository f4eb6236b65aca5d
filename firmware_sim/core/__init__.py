"""firmware_sim.core: one emulated node in one process (docs/node.md, docs/memory-map.md).

Where `hexmigrate` and `pbort` meet: a module file arrives, the loader writes it to flash, and
the PBO/RT kernel runs its code on the node's CPU. Nothing here opens a link or parses a
command line; the other rooms of firmware_sim build on it.

====================  ==========================================================================
``node``              `Node`: CPU, flash, SRAM, loader, kernel and power budget, as one
``cpu``               the RV32IM core on Unicorn: one guest function per call, watchdog, faults
``block_counter``     the CPU's instruction counter, a block hook in C (block_counter.c)
``counters``          the cycle and instret counters a guest reads: the node's, not the host's
``memory_map``        the guest address map (regions, permissions, the task window)
``services``          the kernel services a guest reaches with ecall, and their checks
``sram``              the kernel's SRAM allocator
``flash``             flash in 256-byte blocks, with its timing and power cuts
``flash_space``       which flash blocks belong to which module
``flash_directory``   the power-cut-safe directory of committed modules
``loader``            an extended-HEX module arriving record by record, written to flash
``transfer_target``   `NodeTarget`: what the transfer protocol's receiver loads modules into
``guest``             guest modules as PBOs: registration, ports, methods, evaluators
``repeated_calls``    replaying an estimator's repeated call instead of emulating it again
``source_lines``      a code address -> the function, file and line of C
``natives``           the built-in native PBOs, and loading a user's own
``port_values``       port values as commands give them, and the exact-fit rule
``starting``          starting a PBO with its constants, a refusal told with the module's log
``kernel_log``        the kernel's and the modules' log lines
``power``             the node's power budget
``trust``             which signed modules a node that trusts keys accepts
``fpga_port``         the FPGA reconfiguration port's protocol, found by entry point
``fabric_pbo``        the native ``fabric`` PBO: samples through the port's fabric every cycle
``debug_port``        `DebugPort`: everything a debugger may do to the node
====================  ==========================================================================
"""
