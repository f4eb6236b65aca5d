"""Ports carried between robots: an output on one node feeds an input on another, over the link
between the two, at that link's bit rate in virtual time.

A kernel wires ports within its node (its state-variable table). When ReFrESH runs a module on
another robot than the one that uses its output (a coalition), the value has to cross the link
between the robots. A bridge stands for that link, for one port, and has two halves
(halves.py), the same whatever carries the values between them:

* its exporter, a native PBO on the source node (``NAME_tx``), reads the port every period and
  sends the value as one message: a 3-byte header (type, bridge number, sequence) and the
  port's bytes;
* the message takes the time the modelled wire gives it: serial 8N1, framed as on any serial link
  (COBS between 0x00 delimiters, 10 bits a byte), or CAN, ISO-TP frames at their exact stuffed
  length (`firmware_sim.wires`), with the receiver's flow control frame when it takes more
  than one;
* its importer, a native PBO on the sink node (``NAME_rx``), writes the newest value that has
  arrived by its own cycle.

A value is a periodic state variable, so only the newest one matters: while the wire still
carries the previous value, the exporter skips its period (`stats.skipped`) rather than queue
behind it.

Two transports carry the values between the halves: `PortBridge`, both nodes in one process (the
exporter puts each value straight into the importer's inbox; both nodes must run in step on
comparable virtual clocks, since the importer compares arrival times with its own `now`), and
linked_halves.py, the two nodes in two processes, a link given by URL between them
(value_message.py: the producer's clock and the arrival time travel with the value).

=================  ==================================================================
``halves``         the exporting and importing halves, the wire model, the statistics
``port_bridge``    `PortBridge`: both nodes in one process
``value_message``  one value on a link between two node processes
``linked_halves``  the halves over a link given by URL (a node in each process)
=================  ==================================================================
"""
