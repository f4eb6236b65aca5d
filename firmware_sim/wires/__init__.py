"""Wires in virtual time: a module transfer at the exact bit rate of a UART or a CAN bus.

A small discrete-event simulation drives the real `Sender`, `Receiver` and `Node`; nothing waits
in real time, and the virtual time a transfer takes is what the wire and the node's flash allow.

* Serial is full duplex: each direction is a `WireClock`; a message occupies exactly its framed
  bytes (``framing.frame``: a text line and ``\\n``, a binary message as 0x00 COBS 0x00) times 10
  bits (8N1), and arrives when its last stop bit does.
* CAN is one bus shared by both directions: every ISO-TP frame (single frame; first frame with 6
  message bytes; consecutive frames with 7; the receiver's flow control frame, blocksize 0 and
  STmin 0; all padded to 8 bytes with 0xCC, as `CanLink` sets can-isotp up) takes the exact
  stuffed bit count `can_frame_bits` gives for its identifier and data. When the bus falls idle
  the ready frame with the lowest identifier wins (the host's 0x7E0 before the node's 0x7E8);
  each side sends its frames in the order they became ready and its messages one at a time;
  flow control is answered at once, by the CAN driver, even while the node programs flash.
* The node handles a message when it has arrived and the node is no longer busy; it is busy for
  the flash time each message costs (`Flash.busy_time` deltas: block programming, erases, the
  flash directory write of COMMIT) and replies when that time is over. The host and the node CPU
  take no virtual time.

==============  =============================================================================
``timing``      how long bytes and frames take on a UART and a CAN bus (`WireClock`)
``simulation``  the discrete-event core: units on buses, arbitration, virtual time
``wire_ends``   the two kinds of wire end: a UART's transmit half, one side of an ISO-TP link
``link``        the host's `Link` into the simulation, and the node's end
``transfer``    a whole transfer and its figures (`run_transfer`)
``unwired``     the same transfer with no wire: the software stack alone, and a plain copy
``workload``    the modules measured transfers carry
==============  =============================================================================

benchmarks/migration.py measures with it, the bridges between robots time their values with
`timing`, and an application that migrates a module during a run in virtual time takes the time
it costs from `transfer`.
"""
