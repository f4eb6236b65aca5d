"""`pbort.flow_order`: the rank of each PBO in the ties of a release."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from pbort.flow_order import flow_order


def test_a_chain_registered_against_the_flow_runs_with_it():
    assert flow_order(["c", "b", "a"], [("a", "b"), ("b", "c")]) == {"a": 0, "b": 1, "c": 2}


def test_unwired_pbos_keep_their_registration_order():
    assert flow_order(["x", "a", "y"], []) == {"x": 0, "a": 1, "y": 2}


def test_among_the_pbos_free_to_go_the_one_registered_first_goes():
    """x feeds nothing and is fed by nothing: it keeps its place before the chain's sink."""
    ranks = flow_order(["sink", "x", "source"], [("source", "sink")])
    assert ranks == {"x": 0, "source": 1, "sink": 2}


def test_a_loop_starts_at_its_pbo_registered_first_and_self_wiring_is_no_constraint():
    ranks = flow_order(["b", "a", "c"], [("a", "b"), ("b", "a"), ("a", "c"), ("c", "c")])
    assert ranks == {"b": 0, "a": 1, "c": 2}


def test_wires_of_pbos_not_registered_are_ignored():
    assert flow_order(["a"], [("gone", "a"), ("a", "gone")]) == {"a": 0}


names = st.lists(st.sampled_from("abcdefgh"), min_size=1, max_size=8, unique=True)
wirings = names.flatmap(
    lambda n: st.tuples(st.just(n), st.lists(st.tuples(st.sampled_from(n), st.sampled_from(n))))
)


@given(wirings)
def test_every_pbo_gets_one_place_and_acyclic_wiring_is_respected(case):
    registered, feeds = case
    ranks = flow_order(registered, feeds)
    assert sorted(ranks.values()) == list(range(len(registered)))
    edges = {(s, t) for s, t in feeds if s != t}
    if _acyclic(registered, edges):
        assert all(ranks[s] < ranks[t] for s, t in edges)


def _acyclic(nodes, edges) -> bool:
    left, edges = set(nodes), set(edges)
    while left:
        free = [n for n in left if not any(t == n and s in left for s, t in edges)]
        if not free:
            return False
        left -= set(free)
    return True
