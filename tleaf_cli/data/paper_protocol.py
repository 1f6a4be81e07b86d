"""The authors' data protocol for Table I (`--protocol paper` of gen-formulas and gen-traces).

What clear-nus/T-LEAF's `src/Synthetic/meta_dataset_generation.py` does, on tleaf's DFAs:

* **Formulas** (`spot_formula`): spot's `randltl` at an exact tree size, with the operators the
  authors left on (`ltl_priorities="equiv=0, implies=0, R=0, W=0, M=0, xor=0"`): spot's
  `random_formula::generate(n)` draws, for n = 1, an atom (weight: the number of atoms, each
  atom uniform), `true` or `false` (weight 1 each); for n = 2 one of `! F G X` (weight 1 each)
  over a tree of size 1; for n >= 3 one of `! F G X U & |` (weight 1 each), a unary operator
  over a tree of size n - 1, a binary one over a left tree of size l uniform in 1..n-2 and a
  right tree of size n - 1 - l. Atoms need not all appear. spot then simplifies the formula
  and drops one whose simplified text it has drawn before; tleaf has no spot simplifier, so a
  draw is dropped when its own text was drawn before, and formulas spot would simplify to a
  constant are rejected by the filters below instead (an unsatisfiable one has no accepting
  path, a valid one only the path of length 0).
* **Filters** (`paper_reason`): the automaton has at most 20 states, counted as spot counts
  them (the trimmed automaton: no state from which acceptance is unreachable); the search
  below finds at least 5 accepting paths; and for each path in turn, uniformly drawn words of
  its length are rejected before more than 40 letters have been drawn for it (the authors'
  `checkfalse`: a word of length L is drawn L letters at a time, the count reset at each
  rejected word).
* **Positives** (`paper_positive_words`): `Graph.find_assign`, a depth-first search from the
  initial state that never enters a state already on the path (so no self-loop), records a
  path at the first accepting state it reaches (and does not go past it), and stops at 10
  paths; out-arcs are tried in the order of their target state. An accepting initial state
  gives no path: their search records the empty path there and stops (Graph.py:81-83), and
  one path fails the filter. Each letter of a path is a random completion of one disjunct of
  its arc's guard (`true_complement`): a cube of the guard's irredundant sum of products
  (spot's `bdd_format_formula`) chosen uniformly, the atoms it leaves open set true or false
  with probability 1/2. The set is drawn three times over.
* **Arcs** (`shape`, the `paper_arcs` setting): the search branches once per arc, so what an
  arc is decides how many paths a formula has. The authors' graph has one `Edge` per
  transition spot read from ltlfkit's automaton (`models/Util.py:158-159`, `aut2graph`: `for
  t in aut.out(s)`, labelled `bdd_format_formula(t.cond)`), and `find_assign` branches once
  per `Edge` (`models/Graph.py:85-92`). ltlfkit is not public, so its arcs are read from how
  the code treats a label: `true_complement` splits an arc's label on `|` and draws one part
  (`meta_dataset_generation.py:589-595`), `Graph.checker` splits it on `|`
  (`models/Graph.py:105`), `label_simplify` parses `(cube) | (cube)`
  (`meta_dataset_generation.py:349-361`): an arc's label is a disjunction, so one arc per
  state and successor carrying its whole guard — `guard`, the default. `cube` (an arc per
  cube of the ISOP) and `letter` (an arc per letter) are the other readings: neither would
  ever put a `|` on a label. Kept by `paper_reason` of the first 2,000 distinct
  `spot_formula(random.Random(0), "abc", size)` draws (compiled by `compile_formula`, judged
  with `default_rng([0, 1])` as gen-formulas judges; seconds): size 10 (Low) guard 11 (0.6 %),
  cube 20 (1.0 %), letter 238 (11.9 %); size 20 (Moderate) guard 33 (1.6 %), cube 37
  (1.9 %), letter 372 (18.6 %). Nearly all the rest have fewer than 5 paths. At the default,
  `gen-formulas`' draw limit (50 per formula asked + 1,000) falls short of 1,000 Low
  formulas; `letter` reaches it.
* **Negatives** (`paper_negative_words`): for each positive, a word of the same length with
  every letter uniform over all letters, redrawn until rejected (`random_assignment`): that is
  the uniform distribution over rejected words of that length, drawn here in one go.

Letters are over the formula's own atoms (the authors' traces also fix atoms the formula does
not read, which no automaton reads).
"""

from __future__ import annotations

import random
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from tleaf_cli.errors import SettingError
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.guards import _cover
from tleaf_cli.logic.sampling import WordSampler
from tleaf_cli.settings.data import PAPER_ARCS

UNARY = ("!", "F", "G", "X")
BINARY = ("U", "&", "|")
MAX_STATES = 20  # meta_dataset_generation.py: `if len(graph.nodes) > 20`
MIN_PATHS = 5  # `len(graph.true_assign) >= 5`
MAX_PATHS = 10  # Graph.find_assign: `if len(self.true_assign) >= 10: return`
LETTER_BUDGET = 40  # checkfalse: `if times > 40`
REPEATS = 3  # true_complement: `for i in range(3)`
ARC_SHAPES = PAPER_ARCS  # what one arc is (module docstring): a guard, one of its cubes, a letter

Cube = tuple[int, ...]  # signed 1-based atom indices; () is the cube `true`


class Arc(NamedTuple):
    """One arc of the searched automaton: a letter on it completes one of `cubes`, drawn
    uniformly (the whole guard's cubes, one cube, or one letter's full cube)."""

    src: int
    dst: int
    cubes: tuple[Cube, ...]


Path = list[Arc]  # the arcs of a path from the initial state


def spot_formula(rng: random.Random, atoms: Sequence[str], size: int) -> str:
    """A formula of exactly `size` nodes drawn as spot's randltl draws it (module docstring),
    fully parenthesised in tleaf's syntax."""
    if size == 1:
        pick = rng.randrange(len(atoms) + 2)
        return atoms[pick] if pick < len(atoms) else ("false", "true")[pick - len(atoms)]
    ops = UNARY if size == 2 else UNARY + BINARY
    op = ops[rng.randrange(len(ops))]
    if op in UNARY:
        return f"{op}({spot_formula(rng, atoms, size - 1)})"
    left = rng.randint(1, size - 2)
    right = spot_formula(rng, atoms, size - 1 - left)  # spot draws the right operand first
    return f"({spot_formula(rng, atoms, left)} {op} {right})"


def trimmed_states(dfa: DFA) -> int:
    """States of the DFA from which an accepting state can still be reached: the states of
    the trimmed automaton spot would print (a complete DFA's dead state left out)."""
    return int(dfa.live().sum())


def letter_cube(letter: int, atoms: int) -> Cube:
    """The cube that holds exactly one letter (powerset index): every atom's literal."""
    return tuple(k + 1 if letter >> k & 1 else -(k + 1) for k in range(atoms))


def guard_cubes(dfa: DFA, src: int, dst: int) -> list[Cube]:
    """The cubes (signed 1-based atom indices) of the irredundant sum of products of the
    letters that lead from `src` to `dst`; `()` is the cube `true`."""
    on_letters = dfa.table[src] == dst
    on = sum(1 << i for i in np.flatnonzero(on_letters).tolist())
    cubes, _ = _cover(on, on, len(dfa.atoms), 1)
    return [tuple(c) for c in cubes]


def state_arcs(dfa: DFA, state: int, shape: str, live: np.ndarray) -> list[Arc]:
    """The arcs out of `state` into states that can still accept, in the order the search
    tries them: by target state, then by cube or letter."""
    if shape not in ARC_SHAPES:
        raise SettingError("paper_arcs", f"must be one of {', '.join(ARC_SHAPES)}, not {shape!r}")
    arcs = []
    for dst in np.unique(dfa.table[state]).tolist():
        if not live[dst]:
            continue
        if shape == "letter":
            letters = np.flatnonzero(dfa.table[state] == dst).tolist()
            arcs += [Arc(state, dst, (letter_cube(x, len(dfa.atoms)),)) for x in letters]
            continue
        cubes = tuple(guard_cubes(dfa, state, dst))
        if shape == "guard":
            arcs.append(Arc(state, dst, cubes))
        else:
            arcs += [Arc(state, dst, (cube,)) for cube in cubes]
    return arcs


def accepting_paths(dfa: DFA, limit: int = MAX_PATHS, shape: str = "guard") -> list[Path]:
    """The authors' `Graph.find_assign` on the automaton whose arcs are `shape`: simple paths
    from the initial state, each ending at the first accepting state it reaches, found depth
    first, at most `limit`. No path when the initial state accepts (the authors' search records
    the empty path there and stops, and one path fails their filter)."""
    live = dfa.live()
    arcs: dict[int, list[Arc]] = {}
    paths: list[Path] = []
    on_path = np.zeros(dfa.num_states, dtype=bool)

    def visit(state: int, path: Path) -> None:
        on_path[state] = True
        if state not in arcs:
            arcs[state] = state_arcs(dfa, state, shape, live)
        for arc in arcs[state]:
            if len(paths) >= limit:
                break
            if on_path[arc.dst]:
                continue
            path.append(arc)
            if dfa.accepting[arc.dst]:
                paths.append(list(path))
            else:
                visit(arc.dst, path)
            path.pop()
        on_path[state] = False

    if dfa.accepting[dfa.initial]:
        state_arcs(dfa, dfa.initial, shape, live)  # a bad shape is refused all the same
        return []
    visit(dfa.initial, [])
    return paths


def complete_cube(rng: np.random.Generator, cube: Sequence[int], atoms: int) -> int:
    """A letter (powerset index) inside the cube: its literals as written, every other atom
    true or false with probability 1/2."""
    bits = rng.random(atoms) < 0.5
    for literal in cube:
        bits[abs(literal) - 1] = literal > 0
    return int(sum(1 << k for k in np.flatnonzero(bits).tolist()))


def paper_positive_words(
    dfa: DFA, rng: np.random.Generator, paths: list[Path], repeats: int = REPEATS
) -> list[np.ndarray]:
    """Each path's letters drawn `repeats` times (all paths, then all again): a letter is a
    random completion of a uniformly chosen cube of its arc."""
    words = []
    for _ in range(repeats):
        for path in paths:
            letters = []
            for arc in path:
                options = arc.cubes
                letters.append(
                    complete_cube(rng, options[rng.integers(len(options))], len(dfa.atoms))
                )
            words.append(np.array(letters, dtype=np.int64))
    return words


def paper_negative_words(
    dfa: DFA, rng: np.random.Generator, lengths: Sequence[int]
) -> list[np.ndarray | None]:
    """A uniformly drawn rejected word of each length (None where every word of that length is
    accepted: the authors' loop would not end)."""
    sampler = WordSampler(dfa, max(lengths, default=1))
    rejected = sampler.counts(False)
    return [
        sampler.sample(rng, length, False, 1)[0] if rejected[length] > 0 else None
        for length in lengths
    ]


def rejected_within_budget(
    dfa: DFA, rng: np.random.Generator, paths: list[Path], budget: int = LETTER_BUDGET
) -> bool:
    """The authors' `checkfalse`: for each path in turn, words of its length with uniform
    letters are drawn until one is rejected; False once more than `budget` letters have been
    drawn for one path without a rejected word."""
    size = dfa.alphabet.size
    for path in paths:
        drawn = 0
        while True:
            word = rng.integers(size, size=len(path))
            drawn += len(path)
            if not dfa.accepting[dfa.run(word)]:
                break
            if drawn > budget:
                return False
    return True


def paper_reason(dfa: DFA, rng: np.random.Generator, shape: str = "guard") -> str | None:
    """Why the authors' filters drop this formula's automaton (its arcs `shape`), or None if
    they keep it."""
    if trimmed_states(dfa) > MAX_STATES:
        return f"more than {MAX_STATES} states"
    paths = accepting_paths(dfa, shape=shape)
    if len(paths) < MIN_PATHS:
        return f"fewer than {MIN_PATHS} accepting paths"
    if not rejected_within_budget(dfa, rng, paths):
        return f"no rejected word within {LETTER_BUDGET} letters"
    return None
