"""The paper's section 6 experiment on emulated robots, and the scenarios beyond it: what is the
experiment's own (`visual_servoing.declaration` declares it to the application framework, which
runs it).

=================  =================================================================================
``scenarios``      the paper's scenario and the others: camera faults, a cut servo bus, a power
                   drop, a node's outage (`Faults`: what the world injects)
``world``          `ServoingWorld`: the scene, the servos and the plate around the two robots'
                   nodes, in process, in a node process or beside the manager; the servos' own
                   processes across processes
``firmware``       the task's native modules bound to a robot's devices
``node_firmware``  a robot's firmware in its own node process, with its ``Plate``
``plate``          the plate's pose from the servos' feedback (forward kinematics)
``campaign``       the faults a campaign draws around the scenarios
``paper.toml``     the paper's module database; ``robots.toml`` the one with the rotation robot's
                   camera and matcher as alternatives
=================  =================================================================================
"""
