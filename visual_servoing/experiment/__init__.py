"""The paper's section 6 experiment on emulated robots, and the scenarios beyond it.

`world` holds the two robots (emulated nodes), the HexManipulator's servos and the scene in one
virtual time; `setup` builds the module database, the task's modules and the cameras for a
scenario; `run` drives the task, ReFrESH's decisions and the reconfiguration; `report` writes
the timeline, the JSON report and the plot; `cli` is ``python -m visual_servoing``.
"""
