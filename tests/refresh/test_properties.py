"""Fault location on random databases: Base Choice makes exactly sum(a_i) - n test cases, each
changing one slot, and finds the planted faulty module in every single-fault case, as every other
strategy does; brute force and the adaptive strategy find exactly two planted faults, pairwise
names both among what it names, and the Generator then replaces both."""

from __future__ import annotations

import random

from hypothesis import assume, given, settings
from hypothesis import strategies as st

from refresh.events import EventLog
from refresh.generator import synthesize
from refresh.location import MORE_THAN_ONE_FAULT, STRATEGIES, base_choice, brute_force, pairwise
from refresh.synthetic import current_module, faultable_slots, planted_fault, random_scenario

scenarios = st.builds(
    lambda seed, modules, alternatives, robots: random_scenario(
        random.Random(seed), modules, alternatives, robots
    ),
    st.integers(0, 2**32),
    st.integers(2, 60),
    st.integers(1, 6),
    st.integers(1, 10),
)


def sized(modules: int, alternatives: int, robots: int) -> st.SearchStrategy:
    """Random databases of one size, from a drawn seed."""
    return st.builds(
        lambda seed: random_scenario(random.Random(seed), modules, alternatives, robots),
        st.integers(0, 2**32),
    )


small = sized(10, 3, 2)
"""Databases small enough for brute force (prod(a_i) stays in the thousands)."""
large = sized(40, 3, 3)


@settings(max_examples=60)
@given(scenarios)
def test_base_choice_makes_sum_of_alternatives_minus_n_cases(scenario):
    database, current = scenario.database, scenario.configuration
    cases = list(base_choice.cases(current, database))
    a = [len(database.placements(s)) for s in current.schemas]
    n = sum(1 for a_i in a if a_i > 1)
    assert (
        len(cases) == sum(a_i for a_i in a if a_i > 1) - n == base_choice.count(current, database)
    )
    configurations = []
    for slot, option in cases:
        configuration = current.replace(slot, option)
        changed = [
            s for s in range(len(current.chains)) if configuration.chains[s] != current.chains[s]
        ]
        assert changed == [slot]
        configurations.append(configuration)
    assert len(set(configurations)) == len(cases)


@settings(max_examples=60)
@given(scenarios, st.data())
def test_the_planted_faulty_module_is_found(scenario, data):
    slots = faultable_slots(scenario)
    assume(slots)
    slot = data.draw(st.sampled_from(slots))
    faulty = current_module(scenario, slot).module
    estimator = planted_fault(faulty)
    location = base_choice.locate(
        scenario.configuration, scenario.database, scenario.task, estimator, EventLog()
    )
    assert location.module == faulty
    assert location.slots == (slot,)
    assert estimator.calls == location.tried <= location.total
    choice = synthesize(
        scenario.configuration, [slot], scenario.database, scenario.task, estimator, EventLog()
    )
    assert choice.chosen is not None
    assert faulty not in {p.module for p in choice.chosen.chain}
    feasible = [a.util for _, a in choice.candidates if a.p_t]
    assert choice.assessment.util == min(feasible)


@settings(max_examples=25)
@given(sized(8, 3, 2), st.data())
def test_every_strategy_names_a_single_fault_and_brute_force_costs_most(scenario, data):
    slots = faultable_slots(scenario)
    assume(slots)
    faulty = current_module(scenario, data.draw(st.sampled_from(slots))).module
    args = (scenario.configuration, scenario.database, scenario.task)
    calls = {}
    for name, locate in STRATEGIES.items():
        estimator = planted_fault(faulty)
        location = locate(*args, estimator, EventLog())
        assert location.modules == (faulty,), name
        assert estimator.calls == location.tried
        calls[name] = estimator.calls
    assert calls["base-choice"] <= calls["brute-force"]
    assert calls["brute-force"] == brute_force.count(scenario.configuration, scenario.database)


def two_faults(scenario, data) -> tuple[list[int], tuple[str, ...]]:
    """Two planted faulty modules, each running in its own slot: their slots and names."""
    slots = faultable_slots(scenario)
    assume(len(slots) >= 2)
    chosen = sorted(
        data.draw(st.lists(st.sampled_from(slots), min_size=2, max_size=2, unique=True))
    )
    return chosen, tuple(current_module(scenario, slot).module for slot in chosen)


@settings(max_examples=30)
@given(st.one_of(small, large), st.data(), st.sampled_from(["brute-force", "adaptive"]))
def test_two_planted_faults_are_both_named_and_both_replaced(scenario, data, name):
    args = (scenario.configuration, scenario.database, scenario.task)
    assume(name != "brute-force" or brute_force.count(*args[:2]) <= 5000)
    chosen, faulty = two_faults(scenario, data)
    estimator = planted_fault(*faulty)
    location = STRATEGIES[name](*args, estimator, EventLog())
    assert location.slots == tuple(chosen)
    assert location.modules == faulty
    assert location.module == " and ".join(faulty)
    choice = synthesize(*args[:1], location.slots, *args[1:], estimator, EventLog())
    assert choice.chosen is not None
    assert not set(faulty) & {p.module for p in choice.chosen.configuration.placements}


@settings(max_examples=20)
@given(small, st.data())
def test_pairwise_names_both_of_two_faults_among_what_it_names(scenario, data):
    """Every passing case of the covering array replaces both faults, so both are named; a
    slot that every passing case happened to change is named too (no triple is covered)."""
    chosen, faulty = two_faults(scenario, data)
    estimator = planted_fault(*faulty)
    location = pairwise.locate(
        scenario.configuration, scenario.database, scenario.task, estimator, EventLog()
    )
    assert set(chosen) <= set(location.slots)
    assert estimator.calls == location.tried == location.total


def test_two_faults_are_not_guessed():
    scenario = random_scenario(random.Random(7), 30, 4, 3)
    slots = faultable_slots(scenario)[:2]
    assert len(slots) == 2
    estimator = planted_fault(*(current_module(scenario, s).module for s in slots))
    log = EventLog()
    location = base_choice.locate(
        scenario.configuration, scenario.database, scenario.task, estimator, log
    )
    assert not location.located
    assert location.module == MORE_THAN_ONE_FAULT
    assert location.tried == location.total
    assert log.of_kind("location")[0].message == MORE_THAN_ONE_FAULT
