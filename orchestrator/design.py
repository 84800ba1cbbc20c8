"""The design space: which material goes in which column.

A design is a tuple of material numbers, one per column (column j holds material ``design[j - 1]``, numbered
1..M in the material table). Three spaces share one interface:

- *permutation* (M = C, each material once): the study's problem, C! designs;
- *arrangement* (M > C, each material at most once): a catalogue larger than the stack, M!/(M-C)! designs;
- *repetition* (any material in any number of columns): M^C designs.

Every search, the exhaustive sweep and the design-file checks go through this one class: membership, the
baseline a designer already has, random designs, the neighbourhoods of the local search, random keys for the
continuous optimisers (CMA-ES, particle swarm, differential evolution) and lexicographic ranks (the sweep's
chunks are ranges of ranks).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterator, Sequence

import numpy as np

Design = tuple[int, ...]
"""Material number per column (1-based)."""

PERMUTATION, ARRANGEMENT, REPETITION = "permutation", "arrangement", "repetition"
MOVES = ("swap", "insertion", "replace")


def as_design(design: Sequence[int]) -> Design:
    """Normalise any sequence of integers (numpy's included) to a tuple of ints."""
    return tuple(int(m) for m in design)


@dataclass(frozen=True)
class DesignSpace:
    """``columns`` columns, ``materials`` materials; ``repeat``: a material may fill several columns."""

    columns: int
    materials: int
    repeat: bool = False

    def __post_init__(self):
        for name in ("columns", "materials"):
            value = getattr(self, name)
            if isinstance(value, bool) or int(value) != value or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if not self.repeat and self.materials < self.columns:
            raise ValueError(
                f"{self.materials} materials cannot fill {self.columns} columns with each material at "
                f"most once; give at least {self.columns} materials or allow repeats"
            )

    @classmethod
    def permutations(cls, columns: int) -> "DesignSpace":
        return cls(columns, columns)

    @property
    def kind(self) -> str:
        if self.repeat:
            return REPETITION
        return PERMUTATION if self.materials == self.columns else ARRANGEMENT

    @property
    def size(self) -> int:
        """How many designs the space holds."""
        return self.materials**self.columns if self.repeat else math.perm(self.materials, self.columns)

    def describe(self) -> str:
        if self.kind == PERMUTATION:
            return f"every order of {self.materials} materials over {self.columns} columns ({self.size:,} orders)"
        if self.kind == ARRANGEMENT:
            return f"{self.columns} of {self.materials} materials, each at most once ({self.size:,} arrangements)"
        return f"any of {self.materials} materials in each of {self.columns} columns ({self.size:,} designs)"

    # ---------------------------------------------------------------------------------------- membership
    def contains(self, design: Sequence[int]) -> bool:
        return self.problem(design) is None

    def problem(self, design: Sequence[int]) -> str | None:
        """Why ``design`` is not in this space (one phrase), or None when it is."""
        try:
            design = as_design(design)
        except (TypeError, ValueError):
            return f"{design!r} is not a sequence of material numbers"
        if len(design) != self.columns:
            return f"{len(design)} materials for {self.columns} columns"
        outside = [m for m in design if not 1 <= m <= self.materials]
        if outside:
            return f"material {outside[0]} is not in 1..{self.materials}"
        if not self.repeat and len(set(design)) != len(design):
            twice = next(m for m in design if design.count(m) > 1)
            return f"material {twice} is used twice (each material at most once)"
        return None

    def check(self, design: Sequence[int], what: str = "design") -> Design:
        """``design`` as a tuple, or a ValueError saying why it is not in this space."""
        problem = self.problem(design)
        if problem is not None:
            raise ValueError(
                f"{what} {list(design) if isinstance(design, (list, tuple)) else design}: {problem} "
                f"(allowed: {self.describe()})"
            )
        return as_design(design)

    # ---------------------------------------------------------------------------------------- baselines
    def baseline(self) -> Design:
        """The design a designer already has: materials 1..C in order (graded 1..M when M < C)."""
        if self.materials >= self.columns:
            return tuple(range(1, self.columns + 1))
        return tuple(j * self.materials // self.columns + 1 for j in range(self.columns))

    def random(self, rng: np.random.Generator) -> Design:
        if self.repeat:
            return tuple(int(m) + 1 for m in rng.integers(0, self.materials, self.columns))
        return tuple(int(m) + 1 for m in rng.permutation(self.materials)[: self.columns])

    # ---------------------------------------------------------------------------------------- random keys
    @property
    def key_dimension(self) -> int:
        """Length of a random-key vector: one key per material, or one per column with repetition."""
        return self.columns if self.repeat else self.materials

    def from_keys(self, keys: np.ndarray) -> Design:
        """Random-key decoding. Without repetition the materials sorted by their keys fill the columns in order
        (the first C of them: ``argsort(keys) + 1`` for a permutation); with repetition key j in [0, 1] picks
        column j's material, ``floor(key * M) + 1``. A stable sort keeps ties (keys clipped to a bound)
        deterministic."""
        keys = np.asarray(keys, dtype=float)[: self.key_dimension]
        if self.repeat:
            return tuple(
                int(min(self.materials - 1, max(0, math.floor(k * self.materials)))) + 1
                for k in np.nan_to_num(keys, nan=0.5)
            )
        return tuple(int(i) + 1 for i in np.argsort(keys, kind="stable")[: self.columns])

    def to_keys(self, design: Sequence[int], dimension: int | None = None) -> np.ndarray:
        """Evenly spaced keys in [0, 1] that ``from_keys`` decodes to ``design``; extra dimensions get 0.5."""
        design = self.check(design)
        keys = np.full(max(dimension or self.key_dimension, self.key_dimension), 0.5)
        if self.repeat:
            keys[: self.columns] = [(m - 0.5) / self.materials for m in design]
            return keys
        spacing = max(self.materials - 1, 1)
        unused = [m for m in range(1, self.materials + 1) if m not in design]
        for position, material in enumerate(list(design) + unused):
            keys[material - 1] = position / spacing if self.materials > 1 else 0.5
        return keys

    # ---------------------------------------------------------------------------------------- moves
    def neighbours(self, design: Sequence[int]) -> dict[str, list[Design]]:
        """Every distinct design one move away, by move: ``swap`` (two columns exchange their materials),
        ``insertion`` (a column's material taken out and put back elsewhere, the others shifting) and
        ``replace`` (a column takes a material it does not have: an unused one, or with repetition any
        other). A design reachable by several moves is listed under the first."""
        p = as_design(design)
        n = len(p)
        seen: set[Design] = {p}
        moves: dict[str, list[Design]] = {move: [] for move in MOVES}

        def add(move: str, q: list[int]) -> None:
            t = tuple(q)
            if t not in seen:
                seen.add(t)
                moves[move].append(t)

        for i in range(n):
            for j in range(i + 1, n):
                q = list(p)
                q[i], q[j] = q[j], q[i]
                add("swap", q)
        for i in range(n):
            for j in range(n):
                if i != j:
                    q = list(p)
                    q.insert(j, q.pop(i))
                    add("insertion", q)
        candidates = range(1, self.materials + 1)
        for i in range(n):
            for material in candidates:
                if material != p[i] and (self.repeat or material not in p):
                    q = list(p)
                    q[i] = material
                    add("replace", q)
        return moves

    def neighbour_list(self, design: Sequence[int]) -> list[Design]:
        moves = self.neighbours(design)
        return [d for move in MOVES for d in moves[move]]

    def random_move(self, rng: np.random.Generator, design: Sequence[int], swap_probability: float = 0.5) -> Design:
        """One random move: a replacement with probability (moves available)/(all moves) when the space has
        replacements, else a swap (probability ``swap_probability``) or an insertion."""
        p = list(as_design(design))
        n = len(p)
        replacements = (self.materials - 1) if self.repeat else (self.materials - n)
        if replacements > 0 and (n < 2 or rng.random() < replacements / (replacements + n - 1)):
            i = int(rng.integers(n))
            options = [m for m in range(1, self.materials + 1) if m != p[i] and (self.repeat or m not in p)]
            p[i] = int(options[int(rng.integers(len(options)))])
            return tuple(p)
        if n < 2:
            return tuple(p)
        i, j = (int(k) for k in rng.choice(n, size=2, replace=False))
        if rng.random() < swap_probability:
            p[i], p[j] = p[j], p[i]
        else:
            p.insert(j, p.pop(i))
        return tuple(p)

    # ---------------------------------------------------------------------------------------- ranks
    def rank(self, design: Sequence[int]) -> int:
        """The design's lexicographic rank in this space (0 for the smallest tuple)."""
        design = self.check(design)
        if self.repeat:
            rank = 0
            for material in design:
                rank = rank * self.materials + (material - 1)
            return rank
        rank = 0
        pool = list(range(1, self.materials + 1))
        for position, material in enumerate(design):
            digit = pool.index(material)
            rank += digit * math.perm(self.materials - 1 - position, self.columns - 1 - position)
            pool.pop(digit)
        return rank

    def unrank(self, rank: int) -> Design:
        """The design of lexicographic rank ``rank`` (the inverse of :meth:`rank`)."""
        rank = int(rank)
        if not 0 <= rank < self.size:
            raise ValueError(f"rank must be in [0, {self.size}), got {rank}")
        if self.repeat:
            digits = []
            for _ in range(self.columns):
                rank, digit = divmod(rank, self.materials)
                digits.append(digit + 1)
            return tuple(reversed(digits))
        pool = list(range(1, self.materials + 1))
        design = []
        for position in range(self.columns):
            digit, rank = divmod(rank, math.perm(self.materials - 1 - position, self.columns - 1 - position))
            design.append(pool.pop(digit))
        return tuple(design)

    def designs(self, start: int, stop: int) -> Iterator[Design]:
        """The designs of ranks start..stop-1, in rank order, decoding only the first."""
        if start >= stop:
            return
        p = list(self.unrank(start))
        for _ in range(stop - start):
            yield tuple(p)
            if not self._advance(p):
                return

    def _advance(self, p: list[int]) -> bool:
        """The next design in lexicographic order, in place; False after the last."""
        m, n = self.materials, self.columns
        if self.repeat:
            for i in range(n - 1, -1, -1):
                if p[i] < m:
                    p[i] += 1
                    p[i + 1 :] = [1] * (n - 1 - i)
                    return True
            return False
        if m == n:  # a permutation: Knuth's algorithm L
            i = n - 2
            while i >= 0 and p[i] >= p[i + 1]:
                i -= 1
            if i < 0:
                return False
            j = n - 1
            while p[j] <= p[i]:
                j -= 1
            p[i], p[j] = p[j], p[i]
            p[i + 1 :] = reversed(p[i + 1 :])
            return True
        for i in range(n - 1, -1, -1):  # an arrangement: raise the rightmost column that can be raised
            used = set(p[:i])
            larger = [v for v in range(p[i] + 1, m + 1) if v not in used]
            if larger:
                p[i] = larger[0]
                free = [v for v in range(1, m + 1) if v not in used and v != p[i]]
                p[i + 1 :] = free[: n - 1 - i]
                return True
        return False

    @property
    def key(self) -> str:
        """A stable text identity (journal keys, fingerprints)."""
        return f"{self.kind}:{self.columns}of{self.materials}"


__all__ = ["ARRANGEMENT", "Design", "DesignSpace", "MOVES", "PERMUTATION", "REPETITION", "as_design"]
