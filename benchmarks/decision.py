"""ReFrESH decision figures: locate (Base Choice) + synthesize + choose, per decision.

On random module databases of 5 to 200 modules (up to 6 alternatives per schema, up to 10 robots,
a fault planted in a random slot that has alternatives; `refresh.synthetic`), prints for each size
the Base Choice test cases against brute force (prod(a_i)), how many of them the Locator estimated
before naming the fault, the candidates the Generator assessed, and the time per decision (median
and worst over the databases). Then the paper's section 6 scenario. Estimates are plain functions,
so the figures are the cost of the decision making itself. Goal: under 20 ms per decision for 100
modules, under 1 ms for the paper's scenario.

    python benchmarks/decision.py [--quick]
"""

from __future__ import annotations

import argparse
import random
import statistics
import time
from pathlib import Path

from refresh.adaptation import decide
from refresh.configuration import Configuration, initial_configuration
from refresh.estimators.base import Values
from refresh.estimators.function import FunctionEstimator
from refresh.events import EventLog
from refresh.load import load
from refresh.location import base_choice, brute_force
from refresh.synthetic import current_module, faultable_slots, planted_fault, random_scenario

SIZES = (5, 10, 25, 50, 100, 200)
PAPER = Path(__file__).parents[1] / "refresh" / "data" / "visual_servoing.toml"


def random_decisions(modules: int, databases: int, seed: int) -> dict[str, float]:
    """Time one decision on each of `databases` random databases of `modules` modules."""
    rng = random.Random(seed)
    times, cases, brute, tried, assessed = [], [], [], [], []
    while len(times) < databases:
        scenario = random_scenario(rng, modules, max_alternatives=6, robots=10)
        slots = faultable_slots(scenario)
        if not slots:
            continue
        faulty = current_module(scenario, rng.choice(slots)).module
        estimator = planted_fault(faulty)
        args = (scenario.configuration, scenario.database, scenario.task)
        start = time.perf_counter()
        decision = decide(*args, estimator, EventLog())
        times.append(time.perf_counter() - start)
        assert decision.location.module == faulty and decision.target is not None
        cases.append(base_choice.count(scenario.configuration, scenario.database))
        brute.append(brute_force.count(scenario.configuration, scenario.database))
        tried.append(decision.location.tried)
        assessed.append(len(decision.choice.candidates))
    return {
        "cases": statistics.mean(cases),
        "brute": statistics.mean(brute),
        "tried": statistics.mean(tried),
        "candidates": statistics.mean(assessed),
        "median_ms": statistics.median(times) * 1e3,
        "max_ms": max(times) * 1e3,
    }


def noisy_camera(configuration: Configuration) -> Values:
    """The paper's fault: CamReader's image is too noisy unless a Dehazer follows it."""
    modules = [p.module for p in configuration.placements]
    if "CamReader" in modules and modules[modules.index("CamReader") + 1] != "Dehazer":
        return {"diff": 80.0}
    return {"diff": 12.0}


def paper_decision(repeats: int) -> tuple[str, float]:
    """The section 6 decision: the chosen configuration and the median time."""
    loaded = load(PAPER)
    assert loaded.task is not None
    current = initial_configuration(loaded.task, loaded.database)
    times = []
    label = ""
    for _ in range(repeats):
        estimator = FunctionEstimator(noisy_camera)
        start = time.perf_counter()
        decision = decide(current, loaded.database, loaded.task, estimator, EventLog())
        times.append(time.perf_counter() - start)
        assert decision.target is not None
        label = decision.target.label()
    return label, statistics.median(times) * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer databases per size")
    parser.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    options = parser.parse_args()
    databases = 5 if options.quick else 30
    print(f"decision = locate + synthesize + choose; {databases} random databases per size")
    print(
        f"{'modules':>7}  {'BC cases':>8}  {'brute force':>12}  {'BC tried':>8}  "
        f"{'candidates':>10}  {'median ms':>9}  {'max ms':>7}"
    )
    for size in SIZES:
        row = random_decisions(size, databases, options.seed + size)
        print(
            f"{size:>7}  {row['cases']:>8.1f}  {row['brute']:>12.3g}  {row['tried']:>8.1f}  "
            f"{row['candidates']:>10.1f}  {row['median_ms']:>9.3f}  {row['max_ms']:>7.3f}"
        )
    label, median = paper_decision(50 if options.quick else 500)
    print(f"paper scenario (section 6): 3 BC cases against 8, chose {label} in {median:.3f} ms")


if __name__ == "__main__":
    main()
