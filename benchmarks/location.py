"""Fault location strategies compared on the same random databases and planted faults.

For each database size and each number of planted faults (one, two: modules of distinct slots
that have alternatives; `refresh.synthetic`), every strategy of `refresh.location` locates on the
same databases, and the table gives per strategy: the test cases it generated, how many
configurations it estimated, its accuracy (the runs in which it named exactly the planted faulty
modules) and its time per location (median). Brute force is run only where prod(a_i) is at most
`--brute-limit`; above, its count is printed and the rest left blank. Estimates are plain
functions, so the times are the cost of the location itself.

Goals: on double faults the adaptive strategy locates both modules in at least 90 % of the runs
with fewer estimates than brute force; on single faults Base Choice generates sum(a_i) - n cases
(checked on every database: the benchmark stops if not).

    python benchmarks/location.py [--quick] [--seed S] [--brute-limit N]
"""

from __future__ import annotations

import argparse
import random
import statistics
import time
from dataclasses import dataclass, field, replace

from refresh.events import EventLog
from refresh.location import STRATEGIES, base_choice, brute_force, strategy
from refresh.location.trials import all_options
from refresh.synthetic import (
    Scenario,
    current_module,
    faultable_slots,
    planted_fault,
    random_scenario,
)

SIZES = (12, 50)
FAULTS = (1, 2)
ADAPTIVE_ACCURACY_GOAL = 0.90


@dataclass
class Tally:
    """One strategy's figures over the databases of one size and fault count."""

    generated: list[int] = field(default_factory=list)
    estimated: list[int] = field(default_factory=list)
    correct: int = 0
    runs: int = 0
    seconds: list[float] = field(default_factory=list)
    skipped: int = 0

    @property
    def accuracy(self) -> float:
        return self.correct / self.runs if self.runs else float("nan")


def planted(rng: random.Random, modules: int, faults: int) -> tuple[Scenario, tuple[str, ...]]:
    """A random database with `faults` faulty modules, each running in its own slot."""
    while True:
        scenario = random_scenario(rng, modules, max_alternatives=4, robots=4)
        slots = faultable_slots(scenario)
        if len(slots) >= faults:
            chosen = rng.sample(slots, faults)
            return scenario, tuple(current_module(scenario, slot).module for slot in chosen)


def run_one(name: str, scenario: Scenario, faulty: tuple[str, ...], tally: Tally) -> None:
    """Locate with strategy `name` and add its figures to `tally`."""
    task = replace(scenario.task, location=name)
    estimator = planted_fault(*faulty)
    start = time.perf_counter()
    locate = strategy(name)
    location = locate(scenario.configuration, scenario.database, task, estimator, EventLog())
    tally.seconds.append(time.perf_counter() - start)
    tally.runs += 1
    tally.correct += set(location.modules) == set(faulty)
    tally.generated.append(location.total)
    tally.estimated.append(estimator.calls)


def compare(modules: int, faults: int, databases: int, seed: int, limit: int) -> dict[str, Tally]:
    """Every strategy on the same `databases` databases of `modules` modules."""
    rng = random.Random(seed)
    tallies = {name: Tally() for name in STRATEGIES}
    for _ in range(databases):
        scenario, faulty = planted(rng, modules, faults)
        configuration, database = scenario.configuration, scenario.database
        options = all_options(configuration, database)
        expected = sum(len(o) for o in options) - len(options)
        generated = sum(1 for _ in base_choice.cases(configuration, database))
        if generated != expected:
            raise SystemExit(f"Base Choice generated {generated} cases, sum(a_i) - n = {expected}")
        for name, tally in tallies.items():
            over = brute_force.count(configuration, database) > min(limit, brute_force.LIMIT)
            if name == brute_force.NAME and over:
                tally.skipped += 1
                tally.generated.append(brute_force.count(configuration, database))
                continue
            run_one(name, scenario, faulty, tally)
    return tallies


def row(name: str, tally: Tally) -> str:
    generated = statistics.mean(tally.generated)
    if not tally.runs:
        return f"  {name:<12} {generated:>10.3g}  {'(not run: above the limit)':>40}"
    return (
        f"  {name:<12} {generated:>10.3g}  {statistics.mean(tally.estimated):>9.1f}  "
        f"{tally.accuracy:>8.0%}  {statistics.median(tally.seconds) * 1e3:>9.3f}"
        + (f"  ({tally.skipped} above the limit)" if tally.skipped else "")
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer databases per row")
    parser.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    parser.add_argument(
        "--brute-limit",
        type=int,
        default=20_000,
        help="run brute force only up to this many configurations (default 20000; it refuses "
        f"more than {brute_force.LIMIT} itself)",
    )
    options = parser.parse_args()
    databases = 20 if options.quick else 100
    print(f"fault location: {databases} random databases per row, the same for every strategy")
    goals = []
    for size in SIZES:
        for faults in FAULTS:
            tallies = compare(size, faults, databases, options.seed + size, options.brute_limit)
            print(f"{size} modules, {faults} fault{'s' if faults > 1 else ''}")
            print(
                f"  {'strategy':<12} {'generated':>10}  {'estimated':>9}  {'accuracy':>8}  "
                f"{'median ms':>9}"
            )
            for name, tally in tallies.items():
                print(row(name, tally))
            if faults == 2:
                goals.append((size, tallies["adaptive"], tallies[brute_force.NAME]))
    for size, adaptive, brute in goals:
        fewer = statistics.mean(adaptive.estimated) < statistics.mean(brute.generated)
        met = adaptive.accuracy >= ADAPTIVE_ACCURACY_GOAL and fewer
        print(
            f"goal, {size} modules, 2 faults: adaptive {adaptive.accuracy:.0%} located "
            f"(>= {ADAPTIVE_ACCURACY_GOAL:.0%}) with {statistics.mean(adaptive.estimated):.1f} "
            f"estimates against brute force's {statistics.mean(brute.generated):.3g}: "
            f"{'met' if met else 'NOT met'}"
        )
    print("goal, single faults: Base Choice generated sum(a_i) - n on every database: met")


if __name__ == "__main__":
    main()
