"""The summary table: the worst value of the figure's field is read by its keys, so a summary
read back from JSON whose keys come in another order prints the same line."""

from __future__ import annotations

from application.report import table

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
