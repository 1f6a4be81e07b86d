"""LTLf → DFA in this process, by formula progression: the fast path beside MONA.

MONA costs a process per formula (~5 ms) and reads every formula through a second-order encoding;
the random rules and small knowledge-base formulas tleaf compiles by the thousand have DFAs of a
handful of states that progression builds in well under a millisecond.

**Progression.** The formula is put in negation normal form (NNF: negations on atoms only; `!X`
becomes `WX !`, `!F` `G !`, `!U` `R` with negated operands, `->` and `<->` expanded), with equal
subformulas shared. A state is what the rest of the trace must satisfy: a positive Boolean
combination of *obligations* `(ψ, strong)` — "the rest is non-empty and satisfies ψ" — and
`(ψ, weak)` — "the rest is empty or satisfies ψ". Reading a letter σ turns a formula into the
obligations it leaves (De Giacomo & Vardi's progression, with LTLf's two nexts):

    δ(p) = p ∈ σ            δ(X ψ) = (ψ, strong)         δ(F ψ) = δ(ψ) ∨ (F ψ, strong)
    δ(last) = (false, weak)  δ(WX ψ) = (ψ, weak)          δ(G ψ) = δ(ψ) ∧ (G ψ, weak)
    δ(ψ U χ) = δ(χ) ∨ (δ(ψ) ∧ (ψ U χ, strong))            δ(ψ R χ) = δ(χ) ∧ (δ(ψ) ∨ (ψ R χ, weak))

and ∧, ∨ distribute. An obligation is discharged by progressing its ψ on the next letter; at the end
of the trace strong ones are false and weak ones true, which decides acceptance. A state is kept
as the set of minimal cubes of its (monotone) DNF, cubes as bitmasks over obligation ids: that
form is unique for a monotone function of the obligations, so equal states meet and the
construction ends (finitely many obligations). States that differ in form but not in language are
merged by the minimisation that follows (`DFA.minimize_nonempty`), so the result is *the* minimal
DFA — the same table MONA's route gives, which the tests check formula by formula.

**Many atoms.** Progression visits every letter of every state, and its states are sets of
pending obligations, which a conjunction of independent rules multiplies. Over more than
`DIRECT_ATOMS` atoms a top-level `&` or `|` is split: each operand is compiled over its own atoms
and the DFAs are combined by `DFA.product`, which minimises after each step and works with array
operations over the letters (a conjunction of eleven two-atom patterns is eleven small
constructions and ten products).

**Limits.** Work is counted, not timed, so a formula takes the same route on any machine under
any load. A unit of work is one letter read in one cube of a state (a state of c cubes costs
letters × (c + 1), the 1 for the state itself, so a state without cubes, false, costs its
letters too) or one pair of cubes joined when a conjunction of obligations is progressed
(`cube_step`): about 0.5 µs of CPU each on the benchmark machine (benchmarks/progression_work.py),
closer to a construction's time than states × letters, as a state's DNF can hold hundreds of
cubes. A construction that would exceed `max_states` states, or `max_work` units for the whole
formula, raises `TooLarge`, and so does one direct construction past `max_direct_work` units
when that is given (engine "auto"): states kept as DNFs can blow up (nested `<->` double them),
and where MONA is quicker it should do the work. `compile.py` then hands the formula to MONA,
which has its own timeout and memory cap. Whichever route compiles a formula, the DFA is the
same.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from tleaf_cli.errors import TleafError
from tleaf_cli.logic import ltlf_nodes as ltlf
from tleaf_cli.logic.alphabet import Alphabet
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.formulas import check_depth

# Over more atoms than this a top-level & or | is compiled operand by operand and combined.
DIRECT_ATOMS = 4
# Progression gives up (and compile.py uses MONA) beyond these.
MAX_STATES = 2_000
MAX_WORK = 3_000_000  # units of work (module docstring) for the whole formula: about 1.5 s

# NNF node kinds; a node is a tuple (kind, ...) interned to an int id.
TRUE, FALSE, LIT, LAST, NOT_LAST, AND, OR, NEXT, WNEXT, EVENTUALLY, ALWAYS, UNTIL, RELEASE = range(
    13
)
_TRUE_DNF: frozenset[int] = frozenset({0})  # one empty cube
_FALSE_DNF: frozenset[int] = frozenset()  # no cube


class TooLarge(TleafError):
    """The in-process construction would exceed its limits (compile.py then uses MONA)."""


def _too_large(limit: str) -> str:
    return f"progression passed its limit of {limit}; MONA compiles it (engine 'auto' or 'mona')"


@dataclass
class Limits:
    """How far one formula's construction may go, in states and units of work (see the module
    docstring): counted, never timed, so the same formula meets the same limit everywhere."""

    max_states: int = MAX_STATES
    max_work: int = MAX_WORK  # for the whole formula
    max_direct_work: int | None = None  # per direct construction; None: only max_work
    work_done: int = 0

    def count(self, units: int, since: int) -> None:
        """Add `units` of work; TooLarge past `max_work` in all, or past `max_direct_work` since
        `since` (the work done when the direct construction under way began)."""
        self.work_done += units
        if self.work_done > self.max_work:
            raise TooLarge(_too_large(f"{self.max_work:,} units of work"))
        if self.max_direct_work is not None and self.work_done - since > self.max_direct_work:
            limit = f"{self.max_direct_work:,} units of work in one construction"
            raise TooLarge(_too_large(limit))


def progression_dfa(
    formula: ltlf.LTLfFormula, alphabet: Alphabet, limits: Limits | None = None
) -> DFA:
    """The minimal DFA of `formula`'s non-empty traces over `alphabet` (which must hold all of
    the formula's atoms), built in this process; TooLarge past the `limits`."""
    check_depth(formula)
    limits = limits or Limits()
    nodes = _Nodes(alphabet.atoms)
    root = nodes.nnf(formula, False)
    dfa, minimal = _compile_node(nodes, root, alphabet.kind, limits)
    if dfa.alphabet != alphabet:  # atoms the NNF folded away (`a & false`) still make letters
        dfa = DFA(alphabet, dfa.table[:, dfa.alphabet.lift(alphabet)], dfa.initial, dfa.accepting)
    return dfa.minimize_nonempty(minimal=minimal)


def _compile_node(nodes: _Nodes, root: int, kind, limits: Limits) -> tuple[DFA, bool]:
    """Progression from `root` over its own atoms, splitting a top-level &/| over many atoms;
    the DFA's empty-word acceptance is arbitrary. Also whether it is minimal (products are)."""
    atom_ids = nodes.atoms_of(root)
    alphabet = Alphabet(tuple(nodes.atoms[k] for k in atom_ids), kind)
    node = nodes.node(root)
    if len(atom_ids) > DIRECT_ATOMS and node[0] in (AND, OR):
        mode = "and" if node[0] == AND else "or"
        parts = sorted(node[1], key=lambda c: len(nodes.atoms_of(c)))
        dfa, _ = _compile_node(nodes, parts[0], kind, limits)
        for child in parts[1:]:
            part, _ = _compile_node(nodes, child, kind, limits)
            dfa = dfa.product(part, mode, canonical=False)  # numbered once, at the end
            if dfa.num_states > limits.max_states:
                raise TooLarge(_too_large(f"{limits.max_states:,} states"))
        return dfa, True
    letters = _letter_bitmasks(atom_ids, kind)
    return _Progression(nodes, letters, limits).dfa(root, alphabet), False


def _letter_bitmasks(atom_ids: tuple[int, ...], kind) -> list[int]:
    """Each letter of the alphabet over `atom_ids` as a bitmask of global atom indices."""
    if kind == "powerset":
        out = []
        for i in range(1 << len(atom_ids)):
            out.append(sum(1 << a for j, a in enumerate(atom_ids) if i >> j & 1))
        return out
    return [0] + [1 << a for a in atom_ids]


class _Nodes:
    """NNF nodes of one formula, interned: equal subformulas have one id."""

    def __init__(self, atoms: tuple[str, ...]) -> None:
        self.atoms = atoms
        self._atom_index = {a: k for k, a in enumerate(atoms)}
        self._ids: dict[tuple, int] = {}
        self._nodes: list[tuple] = []
        self._atoms_of: dict[int, tuple[int, ...]] = {}
        self.true = self._intern((TRUE,))
        self.false = self._intern((FALSE,))

    def node(self, i: int) -> tuple:
        return self._nodes[i]

    def _intern(self, node: tuple) -> int:
        i = self._ids.get(node)
        if i is None:
            i = self._ids[node] = len(self._nodes)
            self._nodes.append(node)
        return i

    def atoms_of(self, i: int) -> tuple[int, ...]:
        """Sorted global indices of the atoms under node `i`."""
        found = self._atoms_of.get(i)
        if found is None:
            node = self._nodes[i]
            if node[0] == LIT:
                found = (node[1],)
            else:
                below: set[int] = set()
                for child in _children(node):
                    below.update(self.atoms_of(child))
                found = tuple(sorted(below))
            self._atoms_of[i] = found
        return found

    # ---------------------------------------------------------------- smart constructors
    def lit(self, k: int, positive: bool) -> int:
        return self._intern((LIT, k, positive))

    def junction(self, kind: int, children: list[int]) -> int:
        """AND/OR of `children`, flattened, deduplicated, sorted, with constants folded."""
        unit, zero = (self.true, self.false) if kind == AND else (self.false, self.true)
        flat: set[int] = set()
        for c in children:
            if c == zero:
                return zero
            if c == unit:
                continue
            node = self._nodes[c]
            if node[0] == kind:
                flat.update(node[1])
            else:
                flat.add(c)
        if not flat:
            return unit
        if len(flat) == 1:
            return next(iter(flat))
        return self._intern((kind, tuple(sorted(flat))))

    def unary(self, kind: int, child: int) -> int:
        if kind == NEXT and child == self.false:
            return self.false  # a next position that satisfies false: never
        if kind == WNEXT and child == self.true:
            return self.true
        if kind in (EVENTUALLY, ALWAYS) and child in (self.true, self.false):
            return child  # the current position exists: F/G of a constant is the constant
        return self._intern((kind, child))

    def binary(self, kind: int, left: int, right: int) -> int:
        if right in (self.true, self.false):
            return right  # ψ U true, ψ R true = true; ψ U false, ψ R false = false
        return self._intern((kind, left, right))

    # ------------------------------------------------------------------------- NNF
    def nnf(self, f: ltlf.LTLfFormula, neg: bool) -> int:
        """The NNF node of `f`, negated when `neg`; ltlf2dfa's n-ary readings kept:
        `a -> b -> c` is `(a -> b) -> c`, `a U b U c` is `a U (b U c)` (likewise R), and
        `a <-> b <-> c` holds when all operands agree."""
        # ltlf.LTLfTrue/ltlf.LTLfFalse subclass ltlf.LTLfAtomic, so they are tested first.
        if isinstance(f, ltlf.LTLfTrue):
            return self.false if neg else self.true
        if isinstance(f, ltlf.LTLfFalse):
            return self.true if neg else self.false
        if isinstance(f, ltlf.LTLfAtomic):
            return self.lit(self._atom_index[str(f.s)], not neg)
        if isinstance(f, ltlf.LTLfLast):
            return self._intern((NOT_LAST,) if neg else (LAST,))
        if isinstance(f, ltlf.LTLfNot):
            return self.nnf(f.f, not neg)
        if isinstance(f, ltlf.LTLfAnd | ltlf.LTLfOr):
            kind = AND if isinstance(f, ltlf.LTLfAnd) != neg else OR
            return self.junction(kind, [self.nnf(g, neg) for g in f.formulas])
        if isinstance(f, ltlf.LTLfImplies):
            return self._implies(list(f.formulas), neg)
        if isinstance(f, ltlf.LTLfEquivalence):
            pos = [self.nnf(g, False) for g in f.formulas]
            negs = [self.nnf(g, True) for g in f.formulas]
            if neg:  # not all agree: some operand true and some false
                return self.junction(AND, [self.junction(OR, pos), self.junction(OR, negs)])
            return self.junction(OR, [self.junction(AND, pos), self.junction(AND, negs)])
        if isinstance(f, ltlf.LTLfNext | ltlf.LTLfWeakNext):
            kind = NEXT if isinstance(f, ltlf.LTLfNext) != neg else WNEXT
            return self.unary(kind, self.nnf(f.f, neg))
        if isinstance(f, ltlf.LTLfEventually | ltlf.LTLfAlways):
            kind = EVENTUALLY if isinstance(f, ltlf.LTLfEventually) != neg else ALWAYS
            return self.unary(kind, self.nnf(f.f, neg))
        if isinstance(f, ltlf.LTLfUntil | ltlf.LTLfRelease):
            kind = UNTIL if isinstance(f, ltlf.LTLfUntil) != neg else RELEASE
            operands = [self.nnf(g, neg) for g in f.formulas]
            right = operands[-1]
            for left in reversed(operands[:-1]):
                right = self.binary(kind, left, right)
            return right
        raise TypeError(f"no progression for {type(f).__name__}")

    def _implies(self, operands: list[ltlf.LTLfFormula], neg: bool) -> int:
        """`a -> b -> c` is `(a -> b) -> c`, i.e. `!(a -> b) | c`."""
        if len(operands) == 1:
            return self.nnf(operands[0], neg)
        left, right = operands[:-1], operands[-1]
        if neg:  # !(L -> R) = L & !R
            return self.junction(AND, [self._implies(left, False), self.nnf(right, True)])
        return self.junction(OR, [self._implies(left, True), self.nnf(right, False)])


def _children(node: tuple) -> tuple[int, ...]:
    kind = node[0]
    if kind in (AND, OR):
        return node[1]
    if kind in (NEXT, WNEXT, EVENTUALLY, ALWAYS):
        return (node[1],)
    if kind in (UNTIL, RELEASE):
        return (node[1], node[2])
    return ()


class _Progression:
    """The reachable states of one root's progression over a list of letters."""

    def __init__(self, nodes: _Nodes, letters: list[int], limits: Limits):
        self.nodes = nodes
        self.letters = letters
        self.limits = limits
        self._obligation_ids: dict[tuple[int, bool], int] = {}
        self._obligations: list[tuple[int, bool]] = []
        self._delta: dict[tuple[int, int], frozenset[int]] = {}
        self._cube_delta: dict[tuple[int, int], frozenset[int]] = {}
        self._pairs = 0  # pairs of cubes joined by cube_step, not yet counted as work

    # ------------------------------------------------------------------- obligations
    def obligation(self, node: int, strong: bool) -> frozenset[int]:
        """The DNF of one obligation (constants folded: (true, weak) = true, (false, strong) =
        false; (true, strong) is "not the end", (false, weak) "the end")."""
        if (node == self.nodes.true and not strong) or (node == self.nodes.false and strong):
            return _TRUE_DNF if node == self.nodes.true else _FALSE_DNF
        key = (node, strong)
        i = self._obligation_ids.get(key)
        if i is None:
            i = self._obligation_ids[key] = len(self._obligations)
            self._obligations.append(key)
        return frozenset({1 << i})

    def delta(self, i: int, letter: int) -> frozenset[int]:
        """δ(node i, letter) as a DNF over obligations; memoised per (node, letter)."""
        key = (i, letter)
        found = self._delta.get(key)
        if found is not None:
            return found
        node = self.nodes.node(i)
        kind = node[0]
        if kind == TRUE:
            out = _TRUE_DNF
        elif kind == FALSE:
            out = _FALSE_DNF
        elif kind == LIT:
            out = _TRUE_DNF if bool(letter >> node[1] & 1) == node[2] else _FALSE_DNF
        elif kind == LAST:
            out = self.obligation(self.nodes.false, False)
        elif kind == NOT_LAST:
            out = self.obligation(self.nodes.true, True)
        elif kind == AND:
            out = _TRUE_DNF
            for c in node[1]:
                out = _and(out, self.delta(c, letter))
                if not out:
                    break
        elif kind == OR:
            out = _FALSE_DNF
            for c in node[1]:
                out = _or(out, self.delta(c, letter))
                if out == _TRUE_DNF:
                    break
        elif kind == NEXT:
            out = self.obligation(node[1], True)
        elif kind == WNEXT:
            out = self.obligation(node[1], False)
        elif kind == EVENTUALLY:
            out = _or(self.delta(node[1], letter), self.obligation(i, True))
        elif kind == ALWAYS:
            out = _and(self.delta(node[1], letter), self.obligation(i, False))
        elif kind == UNTIL:
            later = _and(self.delta(node[1], letter), self.obligation(i, True))
            out = _or(self.delta(node[2], letter), later)
        else:  # RELEASE
            later = _or(self.delta(node[1], letter), self.obligation(i, False))
            out = _and(self.delta(node[2], letter), later)
        self._delta[key] = out
        return out

    def step(self, state: frozenset[int], letter: int) -> frozenset[int]:
        """The state after `letter`: every obligation of the state progressed."""
        if len(state) == 1:
            for cube in state:
                return self.cube_step(cube, letter)
        out = _FALSE_DNF
        for cube in state:
            out = _or(out, self.cube_step(cube, letter))
            if out == _TRUE_DNF:
                break
        return out

    def cube_step(self, cube: int, letter: int) -> frozenset[int]:
        """A conjunction of obligations after `letter`; memoised, as states share cubes."""
        key = (cube, letter)
        term = self._cube_delta.get(key)
        if term is None:
            term = _TRUE_DNF
            for k in _bits(cube):
                after = self.delta(self._obligations[k][0], letter)
                self._pairs += len(term) * len(after)
                term = _and(term, after)
                if not term:
                    break
            self._cube_delta[key] = term
        return term

    def accepting(self, state: frozenset[int]) -> bool:
        """At the end of the trace strong obligations fail and weak ones hold."""
        strong = 0
        for k, (_, is_strong) in enumerate(self._obligations):
            if is_strong:
                strong |= 1 << k
        return any(cube & strong == 0 for cube in state)

    # ------------------------------------------------------------------ construction
    def dfa(self, root: int, alphabet: Alphabet) -> DFA:
        start = self.obligation(root, True)
        index: dict[frozenset[int], int] = {start: 0}
        states = [start]
        rows: list[list[int]] = []
        step: Callable[[frozenset[int], int], frozenset[int]] = self.step
        limits = self.limits
        since = limits.work_done
        head = 0
        while head < len(states):
            state = states[head]
            head += 1
            limits.count(len(self.letters) * (1 + len(state)), since)  # before a wide row
            row = []
            for letter in self.letters:
                nxt = step(state, letter)
                j = index.get(nxt)
                if j is None:
                    if len(states) >= limits.max_states:
                        raise TooLarge(_too_large(f"{limits.max_states:,} states"))
                    j = index[nxt] = len(states)
                    states.append(nxt)
                row.append(j)
            rows.append(row)
            limits.count(self._pairs, since)
            self._pairs = 0
        accepting = np.array([self.accepting(s) for s in states], dtype=bool)
        return DFA(alphabet, np.array(rows, dtype=np.int32), 0, accepting)


# ----------------------------------------------------------------------- monotone DNFs
def _bits(cube: int):
    while cube:
        low = cube & -cube
        yield low.bit_length() - 1
        cube ^= low


def _absorb(cubes: set[int]) -> frozenset[int]:
    """The minimal cubes: drop any cube that contains another (a ∨ (a ∧ b) = a)."""
    if len(cubes) < 2:
        return frozenset(cubes)
    if len(cubes) == 2:
        a, b = cubes
        both = a & b
        return frozenset((a,) if both == a else (b,) if both == b else (a, b))
    kept: list[int] = []
    for c in sorted(cubes, key=int.bit_count):
        for k in kept:
            if k & c == k:
                break
        else:
            kept.append(c)
    return frozenset(kept)


def _and(a: frozenset[int], b: frozenset[int]) -> frozenset[int]:
    if not a or not b:
        return _FALSE_DNF
    if a == _TRUE_DNF:
        return b
    if b == _TRUE_DNF:
        return a
    return _absorb({x | y for x in a for y in b})


def _or(a: frozenset[int], b: frozenset[int]) -> frozenset[int]:
    if not a:
        return b
    if not b:
        return a
    if a == _TRUE_DNF or b == _TRUE_DNF:
        return _TRUE_DNF
    return _absorb(set(a) | set(b))
