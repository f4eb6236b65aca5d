"""The guest modules in C: built, checked against the database, run on a node's emulated CPU."""

from __future__ import annotations

from pathlib import Path

import pytest

from firmware_sim.core.node import Node
from hexmigrate.image import ModuleImage
from patrol.declaration import APPLICATION
from pbort import PerformanceKind
from pbort.errors import MethodFailedError
from refresh.images import check_images
from refresh.load import loads
from tests.patrol.feeding import feed

F, NF = PerformanceKind.FUNCTIONAL, PerformanceKind.NON_FUNCTIONAL


def test_the_images_agree_with_the_module_database(guest_dir: Path):
    database = APPLICATION.database
    loaded = loads(database.read_text(encoding="utf-8"), database.name, guest_dir)
    check_images(loaded.database, database.name)  # raises on a disagreement


def test_kalman_settles_on_a_noisy_offset_and_reports_its_resources(guest_images):
    with Node("rover1") as node:
        node.load(guest_images["Kalman"])
        node.start("Kalman", 50, constants={"q": 4, "r": 16})
        raw = {"raw": 0}
        feed(node, "Kalman", raw)
        for step in range(100):  # 40 mm, +-6 mm of alternating noise
            raw["raw"] = 40 + (6 if step % 2 else -6)
            node.run(until=0.02 * step + 0.01)
        assert node.kernel.value("Kalman.offset") in range(36, 45)
        performance = node.kernel.performance("Kalman")
        assert performance.latest(F, 0).value == pytest.approx(6, abs=5)  # |innovation|, mm
        assert performance.latest(NF, 1).value == 35.0  # CPU percent, as the database says
        assert performance.latest(NF, 0).value > 0  # power, measured


def test_kalman_refuses_to_start_without_its_noise_figures(guest_images):
    with Node("rover1") as node:
        node.load(guest_images["Kalman"])
        with pytest.raises(MethodFailedError, match="PBO 'Kalman': on returned -1"):
            node.start("Kalman", 50, constants={"q": 4})


@pytest.mark.parametrize(
    ("offset", "heading", "turn"),
    [
        (0, 0, 0),
        (50, 0, -324),  # 50 mm to the left: turn right, 2 v e / (L^2 + e^2)
        (-50, 0, 324),
        (0, 100, -200),  # turned 0.1 rad left: turn right, 2 v L sin(psi) / L^2
    ],
)
def test_pursuit_steers_towards_the_look_ahead_point(guest_images, offset, heading, turn):
    with Node("rover1") as node:
        node.load(guest_images["Pursuit"])
        node.start("Pursuit", 50, constants={"lookahead": 300, "speed": 300})
        feed(node, "Pursuit", {"offset": offset, "heading": heading})
        node.run(until=0.1)
        assert node.kernel.value("Pursuit.turn") == pytest.approx(turn, abs=2)
        assert node.kernel.performance("Pursuit").latest(F, 0).value == abs(offset) / 1000


def test_both_guests_are_relocatable_images_that_migrate(guest_images: dict[str, ModuleImage]):
    for name, image in guest_images.items():
        assert image.name == name
        assert image.relocations  # the descriptor's method pointers: fixed where it lands
