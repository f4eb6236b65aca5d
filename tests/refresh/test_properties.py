"""Base Choice on random databases: exactly sum(a_i) - n test cases, each changing one slot, and
the planted faulty module found in every single-fault case (and where brute force finds it)."""

from __future__ import annotations

import random

from hypothesis import assume, given, settings
from hypothesis import strategies as st

from refresh.estimator import FunctionEstimator
from refresh.events import EventLog
from refresh.generator import synthesize
from refresh.locator import (
    MORE_THAN_ONE_FAULT,
    base_choice_cases,
    base_choice_count,
    locate,
    locate_brute_force,
)
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


@settings(max_examples=60, deadline=None)
@given(scenarios)
def test_base_choice_makes_sum_of_alternatives_minus_n_cases(scenario):
    database, current = scenario.database, scenario.configuration
    cases = list(base_choice_cases(current, database))
    a = [len(database.placements(s)) for s in current.schemas]
    n = sum(1 for a_i in a if a_i > 1)
    assert (
        len(cases) == sum(a_i for a_i in a if a_i > 1) - n == base_choice_count(current, database)
    )
    for case in cases:
        changed = [
            s
            for s in range(len(current.chains))
            if case.configuration.chains[s] != current.chains[s]
        ]
        assert changed == [case.slot]
    assert len({c.configuration for c in cases}) == len(cases)


@settings(max_examples=60, deadline=None)
@given(scenarios, st.data())
def test_the_planted_faulty_module_is_found(scenario, data):
    slots = faultable_slots(scenario)
    assume(slots)
    slot = data.draw(st.sampled_from(slots))
    faulty = current_module(scenario, slot).module
    estimator = planted_fault(faulty)
    location = locate(
        scenario.configuration, scenario.database, scenario.task, estimator, EventLog()
    )
    assert location.module == faulty
    assert location.slot == slot
    assert estimator.calls == location.tried <= location.total
    choice = synthesize(
        scenario.configuration, slot, scenario.database, scenario.task, estimator, EventLog()
    )
    assert choice.chosen is not None
    assert faulty not in {p.module for p in choice.chosen.chain}
    feasible = [a.util for _, a in choice.candidates if a.p_t]
    assert choice.assessment.util == min(feasible)


@settings(max_examples=25, deadline=None)
@given(
    st.builds(
        lambda seed: random_scenario(random.Random(seed), 8, 3, 2),
        st.integers(0, 2**32),
    ),
    st.data(),
)
def test_brute_force_names_the_same_module_at_a_higher_cost(scenario, data):
    slots = faultable_slots(scenario)
    assume(slots)
    faulty = current_module(scenario, data.draw(st.sampled_from(slots))).module
    args = (scenario.configuration, scenario.database, scenario.task)
    base_choice = planted_fault(faulty)
    brute = planted_fault(faulty)
    assert locate(*args, base_choice, EventLog()).module == faulty
    assert locate_brute_force(*args, brute, EventLog()).module == faulty
    assert base_choice.calls <= brute.calls


def test_two_faults_are_not_guessed():
    scenario = random_scenario(random.Random(7), 30, 4, 3)
    slots = faultable_slots(scenario)[:2]
    assert len(slots) == 2
    faulty = {current_module(scenario, s).module for s in slots}
    estimator = planted_fault(faulty.pop())
    second = planted_fault(faulty.pop())

    def both(configuration):
        return {
            "error": max(
                estimator.function(configuration)["error"], second.function(configuration)["error"]
            )
        }

    log = EventLog()
    location = locate(
        scenario.configuration, scenario.database, scenario.task, FunctionEstimator(both), log
    )
    assert not location.located
    assert location.module == MORE_THAN_ONE_FAULT
    assert location.tried == location.total
    assert log.of_kind("location")[0].message == MORE_THAN_ONE_FAULT
