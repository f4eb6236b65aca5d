"""The warehouse patrol: a second task for ReFrESH, larger than the paper's.

Three robots (rover1 patrolling a painted line, rover2 docked with a free CPU, a fixed mast with
an overhead camera), thirteen modules in six schemas with alternatives on all three, two of them
guest modules in C that migrate. It runs on the same runtime as the visual-servoing task
(`refresh.runtime`), with code of its own only for its modules and its scenarios.

============  ==========================================================================
``track``     the patrol line: a stadium, and a pose's offset and heading error against it
``firmware``  the native E-PBOs: sensors, the median filter, the PID, the drives, the chassis
``guest/``    the guest E-PBOs in C: Kalman (filter) and Pursuit (controller)
``guests``    building the guests into the HEX files that migrate
``patrol.toml``  the module database and the task
``scenarios`` the faults of each scenario, set as the modules' fault_at constants
``mission``   one run, whatever runs the robots: the runtime deploying, deciding, repairing
``local``     the robots as three nodes in this process, in one virtual time
``linked``    the robots as node processes, driven over links in lock-step time
``report``    summary, timeline, JSON and the figure
``cli``       ``python -m patrol run | scenarios``
============  ==========================================================================
"""
