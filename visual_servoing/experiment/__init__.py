"""The paper's section 6 experiment on emulated robots, and the scenarios beyond it.

`world` holds the two robots (emulated nodes), the HexManipulator's servos and the scene in one
virtual time; `plate` the plate's pose from the servos' feedback; `firmware` the task's native
modules bound to a robot's devices; `experiment` the run (the task, ReFrESH's decisions and the
reconfiguration) on any world; `report` writes the timeline, the JSON report and the plot; `cli`
is ``python -m visual_servoing``. Across processes: `node` is a robot's node program, `linked`
and `manager` the manager's world over links and its program, `processes` the launcher.
"""
