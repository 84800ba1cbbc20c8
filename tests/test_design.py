"""The design space: membership, ranks, keys and moves, checked against brute-force enumeration."""

import itertools
import math

import numpy as np
import pytest

from orchestrator.design import ARRANGEMENT, PERMUTATION, REPETITION, DesignSpace

pytestmark = pytest.mark.quick  # a first check: python -m pytest -m quick

SPACES = [
    DesignSpace(4, 4),
    DesignSpace(3, 5),
    DesignSpace(4, 3, repeat=True),
    DesignSpace(2, 4, repeat=True),
    DesignSpace(1, 1),
    DesignSpace(1, 3),
]


def brute_force(space):
    """Every design of the space in lexicographic order, from itertools."""
    values = range(1, space.materials + 1)
    if space.repeat:
        return list(itertools.product(values, repeat=space.columns))
    return list(itertools.permutations(values, space.columns))


@pytest.mark.parametrize("space", SPACES, ids=lambda s: s.key)
def test_ranks_enumerate_the_space_in_lexicographic_order(space):
    expected = brute_force(space)
    assert space.size == len(expected)
    assert [space.unrank(r) for r in range(space.size)] == expected
    assert [space.rank(d) for d in expected] == list(range(space.size))
    assert list(space.designs(0, space.size)) == expected
    middle = space.size // 2
    assert list(space.designs(middle, space.size)) == expected[middle:]
    assert all(space.contains(d) for d in expected)


def test_kinds_and_sizes():
    assert DesignSpace(11, 11).kind == PERMUTATION and DesignSpace(11, 11).size == math.factorial(11)
    assert DesignSpace(5, 8).kind == ARRANGEMENT and DesignSpace(5, 8).size == 6720
    assert DesignSpace(7, 3, repeat=True).kind == REPETITION and DesignSpace(7, 3, repeat=True).size == 2187
    with pytest.raises(ValueError, match="at least 5 materials or allow repeats"):
        DesignSpace(5, 3)


@pytest.mark.parametrize("space", SPACES, ids=lambda s: s.key)
def test_keys_round_trip(space):
    rng = np.random.default_rng(1)
    for _ in range(50):
        design = space.random(rng)
        assert space.contains(design)
        assert space.from_keys(space.to_keys(design)) == design
        assert space.contains(space.from_keys(rng.uniform(-0.2, 1.2, space.key_dimension)))


def test_keys_of_a_permutation_are_the_argsort():
    space = DesignSpace(5, 5)
    keys = np.array([0.3, 0.1, 0.9, 0.2, 0.5])
    assert space.from_keys(keys) == tuple(int(i) + 1 for i in np.argsort(keys))


@pytest.mark.parametrize("space", SPACES + [DesignSpace(11, 11)], ids=lambda s: s.key)
def test_neighbours_are_every_design_one_move_away(space):
    rng = np.random.default_rng(2)
    design = space.random(rng)
    moves = space.neighbours(design)
    found = space.neighbour_list(design)
    assert len(found) == len(set(found)) and design not in found
    assert all(space.contains(d) for d in found)
    if space.columns == space.materials == 11:
        assert len(moves["swap"]) == 55 and len(found) == 145  # 55 swaps + 100 insertions - 10 adjacent swaps
        return

    # brute force: every design of the space at one swap, insertion or single-column change
    def one_move(a, b):
        if sum(x != y for x, y in zip(a, b)) == 1:
            return True
        if sorted(a) == sorted(b):
            for i, j in itertools.permutations(range(len(a)), 2):
                q = list(a)
                q.insert(j, q.pop(i))
                if tuple(q) == b:
                    return True
                q = list(a)
                q[i], q[j] = q[j], q[i]
                if tuple(q) == b:
                    return True
        return False

    assert set(found) == {d for d in brute_force(space) if d != design and one_move(design, d)}


@pytest.mark.parametrize("space", SPACES, ids=lambda s: s.key)
def test_random_moves_stay_in_the_space_and_reach_neighbours(space):
    rng = np.random.default_rng(3)
    design = space.random(rng)
    neighbours = set(space.neighbour_list(design)) | {design}
    for _ in range(200):
        moved = space.random_move(rng, design)
        assert space.contains(moved) and moved in neighbours


def test_baselines():
    assert DesignSpace(4, 6).baseline() == (1, 2, 3, 4)
    assert DesignSpace(11, 3, repeat=True).baseline() == (1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3)
    assert DesignSpace(3, 3, repeat=True).baseline() == (1, 2, 3)


def test_problems_are_named():
    space = DesignSpace(3, 4)
    assert space.problem((1, 2)) == "2 materials for 3 columns"
    assert space.problem((1, 2, 5)) == "material 5 is not in 1..4"
    assert space.problem((1, 2, 2)) == "material 2 is used twice (each material at most once)"
    with pytest.raises(ValueError, match=r"order \[1, 1, 2\]: material 1 is used twice"):
        space.check([1, 1, 2], "order")
