"""A node prints its modules' lines as they come, but a module logging every cycle must not
flood the operator's terminal nor block the node on a pipe nobody reads: past
ECHOED_PER_SECOND lines in a second a PBO's lines are held back and counted."""

from __future__ import annotations

from firmware_sim.serving.listen import _echoing
from pbort.module_log import EchoLimit, ModuleLog, attributed


class Clock:
    """A wall clock the test moves."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_a_flood_is_cut_to_the_limit_and_the_held_back_lines_counted():
    clock = Clock()
    limit = EchoLimit(per_second=3, now=clock)
    printed = [limit.shown("noisy", f"line {n}") for n in range(10)]
    assert printed[:3] == [["noisy: line 0"], ["noisy: line 1"], ["noisy: line 2"]]
    assert printed[3:] == [[]] * 7
    clock.now = 101.2
    assert limit.shown("noisy", "line 10") == [
        "noisy: 7 more lines not printed (hexmigrate logs noisy)",
        "noisy: line 10",
    ]
    assert limit.shown("noisy", "line 11") == ["noisy: line 11"]  # the count said once


def test_one_pbo_flooding_does_not_silence_another():
    limit = EchoLimit(per_second=2, now=Clock())
    for n in range(5):
        limit.shown("noisy", f"line {n}")
    assert limit.shown("quiet", "quiet: threshold reached") == ["quiet: threshold reached"]


def test_a_listening_node_says_at_most_the_limit_of_a_module_logging_every_cycle():
    said: list[str] = []
    echo = _echoing(said.append)
    log = ModuleLog()
    for n in range(1000):
        echo("noisy", log.append(0.001 * n, f"sample\x1b[2J {n}"))
    assert 1 <= len(said) <= 2 * 20  # within a second or two of this test's wall clock
    assert all("\x1b" not in line for line in said)  # on one line, escapes shown, not sent
    assert len(log.since(0)) == 64  # the PBO keeps its lines whether printed or not


def test_a_line_names_its_pbo_once_whatever_the_case_the_module_wrote_it_in():
    assert attributed("gain", "k is not configured") == "gain: k is not configured"
    assert attributed("lowpass", "lowpass: cut-off too high") == "lowpass: cut-off too high"
    assert attributed("HexMan", "hexman: bus_off") == "hexman: bus_off"
