"""The scenarios: the paper's experiment, and faults beyond it.

A scenario (`application.scenario.Scenario`) names the module database, a power drop, a node's
outage (killed or cut off, and when it comes back), how long the task runs and, as what the
world injects (`Faults`, the scenario's `plant`), the faults each camera device suffers and when
the first CAN bus to the servos is cut. Every scenario starts from the task's preprogrammed
configuration on the HexManipulator robot; `expected` says what ReFrESH should end up doing, in
words, for the report.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from application.scenario import Outage, PowerDrop, Scenario
from visual_servoing.image_faults import Fault, FaultKind

DATA = Path(__file__).resolve().parent
FAULT_AT = 4.3
"""When the fault strikes, seconds into the run (the paper injects noise at about 4 s)."""


@dataclass(frozen=True)
class Faults:
    """What the world injects: the faults of each camera (by ``Module@robot``, or ``Module`` for
    all its robots), and when the first CAN bus to the servos is cut (None: never)."""

    cameras: dict[str, tuple[Fault, ...]] = field(default_factory=dict)
    servo_link_cut: float | None = None


PAPER = Scenario(
    "paper",
    "noise injected into CamReader (the paper's section 6)",
    "CamReader located by Base Choice; {CamReader, Dehazer, SSD, TrajGen, HexMan} chosen; "
    "the Dehazer migrated and started; the task back within 30 pixels",
    plant=Faults({"CamReader": (Fault(FaultKind.SALT_PEPPER, 0.3, FAULT_AT),)}),
    strikes=(FAULT_AT,),
)

FOG = Scenario(
    "fog",
    "fog on CamReader's lens",
    "CamReader located; the Dehazer restores the contrast: {CamReader, Dehazer, SSD, TrajGen, "
    "HexMan}",
    plant=Faults({"CamReader": (Fault(FaultKind.FOG, 0.6, FAULT_AT),)}),
    strikes=(FAULT_AT,),
)

HARDWARE = DATA / "hardware.toml"

FOG_HARDWARE = Scenario(
    "fog-hardware",
    "fog on CamReader's lens, on a HexManipulator whose CPU cannot run the software Dehazer",
    "CamReader located; the software Dehazer would leave no CPU reserve, so the hardware "
    "Dehazer is chosen: its two partial bitstreams cross the serial line, the fabric's wrappers "
    "reconfigure, and the frames stream through the fabric's median and stretch: "
    "{CamReader, Dehazer_hw, SSD, TrajGen, HexMan}",
    database=HARDWARE,
    plant=Faults({"CamReader": (Fault(FaultKind.FOG, 0.6, FAULT_AT),)}),
    strikes=(FAULT_AT,),
)

TWO_ROBOTS = DATA / "robots.toml"

BLACKOUT = Scenario(
    "blackout",
    "blackout of both cameras on the HexManipulator",
    "no camera of that robot helps (CamReader_alt fails its test case); a coalition with the "
    "rotation robot's camera: {CamReader@rotation, SSD, TrajGen, HexMan}, frames over the link",
    database=TWO_ROBOTS,
    plant=Faults(
        {
            camera: (Fault(FaultKind.BLACKOUT, 1.0, FAULT_AT),)
            for camera in ("CamReader@hexman", "CamReader_alt@hexman")
        }
    ),
    strikes=(FAULT_AT,),
)

POWER_DROP = Scenario(
    "power-drop",
    "the HexManipulator's battery sags to 28 of 100 power units",
    "leftover power 18 <= 20 violates equation (7); moving SSD to the rotation robot leaves 21: "
    "{CamReader, SSD@rotation, TrajGen, HexMan}",
    database=TWO_ROBOTS,
    power_drop=PowerDrop(FAULT_AT, "hexman", 28.0),
)

SECOND_SERVO_BUS = """
[schemas.manipulator.modules.HexMan_alt]
robots = ["hexman"]
inputs = { yaw = "yaw_degrees" }
outputs = { feedback = "crank_degrees", fault = "servo_fault" }
needs = { power = 4 }
source = "native"
frequency = 30

# HexMan's health (functional 1): 1 while its servos answer and follow.
[task.metrics.servos]
schema = "manipulator"
index = 1
threshold = 1
direction = "at_least"
"""

SERVO_CUT = Scenario(
    "servo-cut",
    "the CAN bus from HexMan to its servos is cut",
    "HexMan's evaluator and estimator see the servos silent; HexMan located; HexMan_alt, on the "
    "servos' second CAN bus, takes over: {CamReader, SSD, TrajGen, HexMan_alt}",
    plant=Faults(servo_link_cut=FAULT_AT),
    strikes=(FAULT_AT,),
    extra=SECOND_SERVO_BUS,
)

NO_REPAIR = Scenario(
    "no-repair",
    "blackout of every camera on both robots",
    "no single replacement helps: more than one fault suspected; the task is stopped safely",
    database=TWO_ROBOTS,
    plant=Faults(
        {
            "CamReader": (Fault(FaultKind.BLACKOUT, 1.0, FAULT_AT),),
            "CamReader_alt": (Fault(FaultKind.BLACKOUT, 1.0, FAULT_AT),),
        }
    ),
    strikes=(FAULT_AT,),
)

HEXMAN_CAMERAS = ("CamReader@hexman", "CamReader_alt@hexman")
BLACKOUT_END = 6.5
"""When the HexManipulator's cameras see again in the outage scenarios."""
KILL_AT = 7.0
"""When the rotation robot's node is lost in the outage scenarios (it serves the coalition)."""
SECOND_FAULT = 11.0
"""When the HexManipulator's battery sags in the rejoin scenario (the rejoined node helps)."""


def _dark(*spans: tuple[float, float]) -> dict[str, tuple[Fault, ...]]:
    """The HexManipulator's two cameras black during each span (start, end)."""
    return {
        camera: tuple(Fault(FaultKind.BLACKOUT, 1.0, start, end) for start, end in spans)
        for camera in HEXMAN_CAMERAS
    }


NODE_OUTAGE = Scenario(
    "node-outage",
    "the rotation robot's node is killed (SIGKILL) while its camera serves the task",
    "blackout of the HexManipulator's cameras from 4.3 to 6.5 s: the blackout's coalition "
    "{CamReader@rotation, SSD, TrajGen, HexMan}; at 7 s the rotation robot's node dies: lost, "
    "CamReader located, the task moves back: {CamReader, SSD, TrajGen, HexMan}",
    database=TWO_ROBOTS,
    plant=Faults(_dark((FAULT_AT, BLACKOUT_END))),
    strikes=(FAULT_AT,),
    outage=Outage(KILL_AT, "rotation"),
)

LINK_CUT = Scenario(
    "link-cut",
    "the link to the rotation robot is cut while its camera serves the task, then restored",
    "as node-outage, the link cut at 7 s instead (the node lives on); the task moves back: "
    "{CamReader, SSD, TrajGen, HexMan}; the link restored at 9 s, the node rejoins and its "
    "CamReader, still running, is stopped",
    database=TWO_ROBOTS,
    plant=Faults(_dark((FAULT_AT, BLACKOUT_END))),
    strikes=(FAULT_AT,),
    outage=Outage(KILL_AT, "rotation", kind="cut", back=9.0),
    duration=11.0,
)

REJOIN = Scenario(
    "rejoin",
    "the rotation robot's node is killed, restarts from its flash file and is used again",
    "as node-outage; the node restarts at 8.5 s and rejoins; at 11 s the HexManipulator's "
    "battery sags to 28 of 100 (as power-drop): SSD moves onto the rejoined node, "
    "{CamReader, SSD@rotation, TrajGen, HexMan}",
    database=TWO_ROBOTS,
    plant=Faults(_dark((FAULT_AT, BLACKOUT_END))),
    strikes=(FAULT_AT,),
    outage=Outage(KILL_AT, "rotation", back=8.5),
    power_drop=PowerDrop(SECOND_FAULT, "hexman", 28.0),
    duration=13.0,
)

SCENARIOS = (
    PAPER,
    FOG,
    FOG_HARDWARE,
    BLACKOUT,
    POWER_DROP,
    SERVO_CUT,
    NO_REPAIR,
    NODE_OUTAGE,
    LINK_CUT,
    REJOIN,
)
