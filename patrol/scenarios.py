"""The patrol's scenarios: which modules fail, when, and what ReFrESH should do about it.

A fault is a module's `fault_at` constant (seconds of the run): the native reads it against its
node's clock, live and in a shadow run alike, so the estimators of a faulty module reproduce the
fault and the Locator can tell it from the others (`application.scenario.with_faults`). A patrol
lasts 15 s.
"""

from __future__ import annotations

from application.scenario import Scenario

DURATION = 15.0


GLARE = Scenario(
    "glare",
    "glare blinds rover1's line camera at 1 s",
    "LineCam located; of IRArray and the mast's camera the cheaper is chosen: a coalition, "
    "{MastCam@mast, ...}, rover1's pose bridged up to the mast and the offset back",
    duration=DURATION,
    faults={"LineCam": 1.0},
)

CONTROLLER = Scenario(
    "controller",
    "rover1's PID controller rings (its command flips sign every cycle) at 1 s",
    "PID located; the guest Pursuit is migrated to rover1 and replaces it: "
    "{..., Pursuit@rover1, ...}",
    duration=DURATION,
    faults={"PID": 1.0},
)

FILTER = Scenario(
    "filter",
    "rover1's median filter corrupts its window at 1 s",
    "Median located; the guest Kalman does not fit rover1's CPU (80 % > 75 %), so it migrates to "
    "the docked rover2: a coalition, {..., Kalman@rover2, ...}",
    duration=DURATION,
    faults={"Median": 1.0},
)

TWO_FAULTS = Scenario(
    "two-faults",
    "glare on the line camera at 1 s, then the median filter's corruption at 4 s",
    "first the mast's camera joins (a coalition), which frees rover1's CPU; then Kalman migrates "
    "to rover1 itself: {MastCam@mast, Gyro, Kalman@rover1, PID, Drive, Chassis}",
    duration=DURATION,
    faults={"LineCam": 1.0, "Median": 4.0},
)

RELAY = Scenario(
    "relay",
    "glare on the line camera at 1 s, then the mast's camera blinded at 5 s",
    "first the mast's camera joins (a coalition); when it fails too, LineCam's test case still "
    "fails and IRArray's passes: MastCam located, the coalition ends, the line slot back on "
    "rover1: {IRArray, Gyro, Median, PID, Drive, Chassis}",
    duration=DURATION,
    faults={"LineCam": 1.0, "MastCam": 5.0},
)

BLIND = Scenario(
    "blind",
    "every line sensor blinded at 1 s (the warehouse lights fail)",
    "no single replacement helps: more than one fault suspected; the task is stopped safely "
    "and rover1 halts",
    duration=DURATION,
    faults={"LineCam": 1.0, "IRArray": 1.0, "MastCam": 1.0},
)

HARDWARE_FILTER = """
# Rover1's FPGA: a 2-slot Morphing Crossbar on 32-bit samples whose slot 1 holds the running
# median of five in Verilog (hdl/mx_fn_median5.v). HwMedian is the median filter in hardware:
# its partial bitstream routes input 1 through that median to output 1
# (python -m morphing_crossbar pack 2 1 through wrote it); its E-PBO only moves the offsets.
[robots.rover1.fabric]
slots = ["pass", "median5"]
width = 32

[schemas.filter.modules.HwMedian]
robots = ["rover1"]
inputs = { raw = "offset_raw" }
outputs = { offset = "offset" }
needs = { power = 1, cpu = 2 }
source = { bitstreams = ["HwMedian.slot1.hex"] }
hardware = { functionalities = ["median5"], slots = [1] }
frequency = 50
"""

FILTER_HARDWARE = Scenario(
    "filter-hardware",
    "rover1's median filter corrupts its window at 1 s; rover1 has an FPGA",
    "Median located; the guest Kalman does not fit rover1's CPU, but rover1's fabric holds a "
    "running median: HwMedian's partial bitstream is sent to rover1, no coalition needed: "
    "{..., HwMedian, ...}",
    duration=DURATION,
    faults={"Median": 1.0},
    extra=HARDWARE_FILTER,
)

SCENARIOS = (GLARE, CONTROLLER, FILTER, TWO_FAULTS, RELAY, BLIND, FILTER_HARDWARE)
