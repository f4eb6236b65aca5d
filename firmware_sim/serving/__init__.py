"""firmware_sim.serving: a node on a link, the node side of every host command.

==================  ========================================================================
``listen``          ``firmware-sim listen``: a node that accepts modules and control on a
                    link, with its natives, flash file, trust, traces, gdb and FPGA port
``serve``           the loop that answers a link's messages while the node's PBOs run
``kernel_control``  node control on the kernel: PS, START, STOP, SET, CONNECT, READ, RATE,
                    WATCH, bridges to other node processes, lock-step Advance
``pbo_setup``       what a listening node does with each PBO that arrives: its rate,
                    constants and wires
``node_process``    ``firmware-sim listen`` in a process of its own, as the benchmarks and
                    the tests start a node: its URL read from its log, stopped on the way out
==================  ========================================================================

Where a node listens and the line that says so are the link's business:
`hexmigrate.links.listening`.
"""
