"""The paper's experiment, declared for the application framework: `APPLICATION`.

Two robots (the HexManipulator, where the task runs, and the rotation robot), the task's E-PBOs
(`visual_servoing.task`), the Dehazer as a guest module that migrates over a 115200 baud serial
line, and the world of `visual_servoing.experiment.world`: the scene, the servos and the plate.
A run samples the task at every camera frame (30 per second): the deviation the matcher reports
and the true one, the target, the plate's yaw and the yaw commanded; the figure is the paper's
figure 8, the deviation over time.
"""

from __future__ import annotations

from collections.abc import Mapping

from application.declaration import Application, Figure, SampleField
from refresh.runtime.settings import RuntimeSettings
from visual_servoing.dehazer_guest import INSTRUCTION_BUDGET, NAME, SOURCE
from visual_servoing.errors import ServoingError
from visual_servoing.experiment.campaign import CAMPAIGN
from visual_servoing.experiment.scenarios import DATA, SCENARIOS
from visual_servoing.experiment.world import ServoingWorld
from visual_servoing.task.camera import frame_port

FRAME = 1 / 30
"""Seconds between two samples of the run: one camera frame."""
THRESHOLD = 30.0
"""Pixels: equation (8)'s allowed deviation."""
ROBOT_LINK_BAUD = 12_000_000
"""The serial link between the two robots (ports of a coalition cross it): 12 Mbaud 8N1 carries
a 160 x 120 frame in 16 ms, within a camera period; 115200 baud would need 1.7 s."""


def back(sample: Mapping[str, float]) -> bool:
    """The task is back: the deviation the matcher reports is within the threshold."""
    return abs(sample["reported"]) <= THRESHOLD


APPLICATION = Application(
    name="visual_servoing",
    summary="Run the paper's visual-servoing experiment, or another scenario, on emulated "
    "robots, and write\nwhat happened (the Dehazer is built with riscv64-unknown-elf-gcc).",
    database=DATA / "paper.toml",
    scenarios=SCENARIOS,
    default_scenario="paper",
    guests={NAME: SOURCE},
    hardware={"Dehazer_hw": (frame_port("raw", output=False), frame_port("image", output=True))},
    plant=ServoingWorld,
    sample_fields=(
        SampleField("target", "index of the current target", integer=True),
        SampleField("reported", "deviation SSD reports (pixels)"),
        SampleField("true", "true deviation (pixels)"),
        SampleField("yaw", "the plate's yaw (degrees)"),
        SampleField("command", "the yaw commanded (degrees)"),
    ),
    figure=Figure(
        field="reported",
        label="target deviation from the image centre (px)",
        limit=THRESHOLD,
        file="deviation.png",
        back=back,
        beside="true",
        beside_label="true deviation",
    ),
    # The runtime's defaults but the debounce: a look of the Decider every 3 frames, 0.5 s to
    # settle after a switch (the new configuration's evaluators still hold frames of the old
    # one, and in real time a slow switch left the loop further to go) and for a recovery to
    # hold, 10 estimator steps to fill the matcher's window of frames;
    # a fault after 6 violating looks, as the platform's widest turn alone keeps P_T at 0 for 4
    # (docs/experiment.md, "The run").
    settings=RuntimeSettings(debounce=6),
    sample_period=FRAME,
    step=0.001,
    quantum=0.01,
    link=("serial", ROBOT_LINK_BAUD),
    migration_wire="serial",
    budget=INSTRUCTION_BUDGET,
    listen={"hexman": "pty"},
    report_period=0.01,
    campaign=CAMPAIGN,
    errors=(ServoingError,),
)
