"""The summary table: the worst value of the figure's field is read by its keys, so a summary
read back from JSON whose keys come in another order prints the same line; the time a real-time
run lost is summed from its events and said."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from application.declaration import Application
from application.records import Outcome
from application.report import summary, table
from application.scenario import Scenario
from refresh.events import EventLog
from tests.disk import small_disk

SUMMARY = {
    "scenario": "calm",
    "title": "no fault",
    "faults": [],
    "reconfigurations": [],
    "stopped_at": None,
    "final": "{A, B}",
}


def last_row(shown: str) -> str:
    """The table's last row, its padding collapsed."""
    return " ".join(shown.splitlines()[-1].split())


def test_the_worst_value_is_read_by_its_keys_in_any_order():
    for worst in ({"offset": 42.25, "limit": 100}, {"limit": 100, "offset": 42.25}):
        shown = table({**SUMMARY, "worst": worst})
        assert last_row(shown) == "worst offset 42.2 (the task allows 100)"


def test_a_run_without_samples_has_no_worst_value():
    shown = table({**SUMMARY, "worst": {"limit": 5, "level": None}})
    assert last_row(shown) == "worst level no sample (the task allows 5)"


def lost_and_held(times: list[tuple[str, float]], duration: float = 10.0) -> dict:
    """The summary of a run whose log holds these real-time events, at these times."""
    clock = iter([time for _, time in times])
    log = EventLog(clock=lambda: next(clock), start=0.0)
    for kind, _ in times:
        log.record(kind, kind.replace("_", " "))
    scenario = Scenario("s", "a scenario", "nothing", duration=duration)
    application = Application("app", "An application.", Path("db.toml"), (scenario,), "s")
    return summary(application, Outcome(scenario, configurations=[(0.0, "{A}")], log=log))


def test_real_time_lost_is_summed_over_its_stretches_and_to_the_run_s_end():
    """A loss recorded for two places at once is one stretch; one still open at the end counts
    to the run's end, and the table says a fault may have gone undetected."""
    figures = lost_and_held(
        [
            ("real_time_lost", 1.0),
            ("real_time_lost", 1.0),
            ("real_time_held", 1.5),
            ("real_time_lost", 9.0),
        ]
    )
    assert figures["real_time_lost"] == {"seconds": 1.5, "stretches": 2, "at_the_end": True}
    assert (
        "real time lost 1.500 s in 2 stretch(es), until the run ended: measurements then not "
        "judged (a fault may have gone undetected)"
        in [" ".join(row.split()) for row in table(figures).splitlines()]
    )


def test_a_run_that_held_real_time_says_nothing_of_it():
    figures = lost_and_held([])
    assert "real_time_lost" not in figures
    assert "real time lost" not in table(figures)


def test_a_report_the_disk_refuses_is_an_error_naming_it_and_no_file_is_cut(tmp_path):
    out = tmp_path / "run"
    command = [sys.executable, "-m", "patrol", "run", "--out", str(out)]
    done = subprocess.run(
        command, capture_output=True, text=True, timeout=120, **small_disk(100_000)
    )
    assert done.returncode == 1, done.stderr  # report.json is 140 kB: the first report refused
    assert done.stderr == f"error: {out / 'report.json'}: File too large\n"
    assert not list(out.glob("report.*")) and not list(out.glob("*.partial"))
