"""refresh.remote: the manager's side of nodes over links.

A robot's node runs in another process or on a board (``firmware-sim listen``) and is reached by
a URL (``socket://``, a pty path, ``can://``, ``faulty+...``). On that one link the manager sends
images and control requests and receives the node's pushed reports:

===============  ===================================================================
``reports``      `ReportSource`: a robot's performance buffers from its node's reports
``remote_node``  `RemoteNode`: one node over its link, its requests and its pushes
``guard``        `GuardedControl`: a lock-step time master's view of a node that may be lost
``relay``        `HostRelay`: a bridge the manager carries out of a node that cannot export
===============  ===================================================================

The applier over these nodes is `refresh.appliers.over_links.LinkApplier`.
"""
