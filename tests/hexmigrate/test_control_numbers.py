"""How ``hexmigrate watch`` shows the numbers a node reports: a person reads six significant
digits, a CSV keeps every one (issue 26, point 10)."""

from __future__ import annotations

from hexmigrate.control_cli import _row
from hexmigrate.transfer.messages import PerformanceReport

REPORT = PerformanceReport(3, 2400, "")
VALUES = {"leftover": 99.88329100598311, "gain.y": 6, "gain:F0": 1e-07}


def test_a_row_shows_floats_to_six_digits_and_whole_numbers_as_they_are():
    assert _row(REPORT, [], VALUES, csv=False) == (
        "report #3 t=2.400s  leftover=99.8833  gain.y=6  gain:F0=1e-07"
    )


def test_a_csv_row_keeps_every_digit():
    assert _row(REPORT, list(VALUES), VALUES, csv=True) == "2.400,3,99.88329100598311,6,1e-07"
