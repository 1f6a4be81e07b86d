"""Running MONA safely and reading its automaton.

ltlf2dfa's `to_dfa()` writes one shared file inside site-packages and hides MONA's failures (see
docs/design.md), so tleaf only borrows its MONA encoding (`MonaProgram`) and runs
`mona -q -u -w` itself in a private temporary directory, with a timeout and the exit status
checked.

MONA's automaton reads one extra letter first (its state 0 steps to the real start on any letter);
each `State i: <cube> -> state j` line is a transition on every letter matching the cube, one
character per free variable (`0`, `1`, or `X` for either).
"""

from __future__ import annotations

import contextlib
import os
import re
import resource
import shutil
import signal
import subprocess
import tempfile
from dataclasses import dataclass
from functools import cache
from subprocess import PIPE

import numpy as np
from ltlf2dfa.base import MonaProgram
from ltlf2dfa.ltlf import (
    LTLfAlways,
    LTLfAnd,
    LTLfEquivalence,
    LTLfEventually,
    LTLfFormula,
    LTLfImplies,
    LTLfNext,
    LTLfNot,
    LTLfOr,
    LTLfRelease,
    LTLfUntil,
    LTLfWeakNext,
)

from tleaf_cli.errors import TleafError
from tleaf_cli.logic.alphabet import Alphabet
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.formulas import check_depth

INSTALL_HINT = "install it with: apt-get install -y mona  (Debian/Ubuntu package 'mona')"
DEFAULT_MEMORY_MB = 4096
# The most nodes the MONA encoding of one formula may have. ltlf2dfa's encoding writes the
# operand of G (and R, and of F or U under a negation) twice, so it doubles with each nested
# level: 20 nested G make a 185 MB program (measured) and 25 exhaust the memory of the
# process writing it, before MONA could start. 200,000 nodes is a program of some 20 MB,
# already far beyond what MONA compiles within its timeout.
MAX_ENCODING_NODES = 200_000


class MonaError(TleafError, RuntimeError):
    """MONA failed on a formula (the message says how)."""


class MonaNotFound(MonaError):
    """The `mona` binary is not on PATH."""


class MonaTimeout(MonaError):
    """MONA did not finish within the time limit."""


@dataclass(frozen=True)
class MonaAutomaton:
    """MONA's DFA as printed: free variables (as tleaf atoms), states, transitions on cubes."""

    variables: tuple[str, ...]
    num_states: int
    accepting: frozenset[int]
    transitions: tuple[tuple[int, str, int], ...]


def mona_binary() -> str:
    """Path of `mona`, or MonaNotFound with the command that installs it."""
    path = shutil.which("mona")
    if path is None:
        raise MonaNotFound(f"mona not found on PATH; {INSTALL_HINT}")
    return path


@cache
def mona_version() -> str:
    """MONA's version line, part of the compile cache key."""
    out = subprocess.run([mona_binary(), "-v"], capture_output=True, text=True, timeout=10)
    return (out.stdout.splitlines() or ["unknown"])[0].strip()


def mona_program(formula: LTLfFormula) -> str:
    """ltlf2dfa's MONA encoding of an LTLf formula (header, declarations, formula).

    FormulaSyntaxError when the formula is nested too deeply for the encoding's recursion,
    MonaError when the encoding would be too large to write (it doubles per nested G).
    """
    check_depth(formula)
    nodes = encoding_nodes(formula)
    if nodes > MAX_ENCODING_NODES:
        raise MonaError(
            f"formula too large for MONA: its encoding has about {nodes:,} nodes "
            f"(at most {MAX_ENCODING_NODES:,}; each nested G, R, or <-> doubles it)"
        )
    program = MonaProgram(formula).mona_program()
    # ltlf2dfa's first line repeats the formula as a `#` comment. MONA reads a comment as one
    # token, and no token may pass its reader's buffer (YYLMAX: 8,190 characters measured), so a
    # formula over 8 KB failed on its own comment ("token too large"). The comment is dropped.
    first, _, rest = program.partition("\n")
    return rest if first.startswith("#") else program


def encoding_nodes(formula: LTLfFormula, negated: bool = False, nnf: bool = False) -> int:
    """The nodes of ltlf2dfa's MONA encoding of `formula`, counted without writing it.

    The encoding writes the second operand of R (so of G) twice; -> and <-> are first put in
    negation normal form (`nnf`), where a negated F or U becomes G or R and <-> writes each
    operand in both polarities. Recursive, for a formula `check_depth` has passed.
    """
    f, pol = formula, negated and nnf
    if isinstance(f, LTLfNot):
        return encoding_nodes(f.f, not negated if nnf else False, nnf) + 1
    if isinstance(f, LTLfAnd | LTLfOr):
        return 1 + sum(encoding_nodes(g, pol, nnf) for g in f.formulas)
    if isinstance(f, LTLfImplies):
        return _implies_nodes(list(f.formulas), pol)
    if isinstance(f, LTLfEquivalence):
        return 3 + sum(encoding_nodes(g, p, True) for g in f.formulas for p in (False, True))
    if isinstance(f, LTLfNext | LTLfWeakNext):
        return 1 + encoding_nodes(f.f, pol, nnf)
    if isinstance(f, LTLfEventually | LTLfAlways):
        twice = isinstance(f, LTLfAlways) != pol  # G, or F negated (then a G)
        return 1 + (2 if twice else 1) * encoding_nodes(f.f, pol, nnf)
    if isinstance(f, LTLfUntil | LTLfRelease):
        twice = isinstance(f, LTLfRelease) != pol
        return _chain_nodes(list(f.formulas), pol, nnf, 2 if twice else 1)
    return 1  # atoms, true, false, last


def _implies_nodes(operands: list[LTLfFormula], negated: bool) -> int:
    """`a -> b -> c` is `(a -> b) -> c`, in NNF `!(a -> b) | c`: the left side flips polarity."""
    if len(operands) == 1:
        return encoding_nodes(operands[0], negated, True)
    left = _implies_nodes(operands[:-1], not negated)
    return 2 + left + encoding_nodes(operands[-1], negated, True)


def _chain_nodes(operands: list[LTLfFormula], negated: bool, nnf: bool, factor: int) -> int:
    """`a U b U c` is `a U (b U c)` (likewise R); the right side is written `factor` times."""
    if len(operands) == 1:
        return encoding_nodes(operands[0], negated, nnf)
    right = _chain_nodes(operands[1:], negated, nnf, factor)
    return 1 + encoding_nodes(operands[0], negated, nnf) + factor * right


def run_mona(program: str, timeout: float, memory_mb: int = DEFAULT_MEMORY_MB) -> str:
    """Run MONA on a program text in a private temp dir; its stdout, or MonaError.

    MONA's automata can grow exponentially (21 GB measured for a 22-step look-back), so its
    address space is capped at `memory_mb` as well as its time. The cap is set on the child with
    prlimit right after it starts: a Python preexec_fn would stop subprocess from using vfork
    (15 ms instead of 5 ms per call, measured), and an `sh -c ulimit` wrapper costs an exec.
    `-n` skips MONA's search for example traces, which tleaf does not use.
    """
    binary = mona_binary()
    limit = memory_mb * 1024 * 1024
    with tempfile.TemporaryDirectory(prefix="tleaf-mona-") as tmp:
        path = os.path.join(tmp, "formula.mona")
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(program)
        command = [binary, "-q", "-u", "-w", "-n", path]
        with subprocess.Popen(command, stdout=PIPE, stderr=PIPE, text=True, cwd=tmp) as proc:
            with contextlib.suppress(OSError):  # it may already have finished
                resource.prlimit(proc.pid, resource.RLIMIT_AS, (limit, limit))
            try:
                out, err = proc.communicate(timeout=timeout)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.communicate()
                raise MonaTimeout(f"MONA did not finish within {timeout:g} s") from None
    if proc.returncode != 0:
        raise MonaError(failure_reason(proc.returncode, out, err, memory_mb))
    return out


# What MONA's failures mean, and what to do about each; one line, for a row's error.
SPLIT_ADVICE = "a conjunction into one formula per conjunct, which tl.RuleSet conjoins as one DFA"
TOO_MANY_STATES = (
    "the formula has too many states for MONA; split it into smaller formulas (a conjunction "
    "into one formula per conjunct) or give each fewer eventualities (F, U)"
)


def failure_reason(returncode: int, out: str, err: str, memory_mb: int) -> str:
    """A failed MONA run's cause, read from its exit status and what it printed, with what to do.

    - "token too large, exceeds YYLMAX": MONA's reader takes no word longer than its buffer
      (8,190 characters measured); with ltlf2dfa's comment dropped, only an atom name can be.
    - "*** out of memory, execution aborted ***" (stdout, exit status 255): the address-space
      cap set on the child was reached.
    - "memory exhausted" then "Execution aborted" (exit status 255): MONA's parser (bison) keeps
      at most 10,000 symbols pending, three per operand of a chain of `&` or `|`, so no chain
      of more than 3,331 operands can be read (measured: `a0 & ... & a3330` compiles, one more
      operand does not), whatever the memory cap.
    - killed by SIGABRT with nothing printed: MONA aborts when an automaton outgrows its BDD
      table (`bdd_new_manager` prints "BDD too large" and calls abort(), so its buffered stdout
      is lost): 20 eventualities `F a1 & ... & F a20` (2^20 states) do it within seconds.
    """
    text = f"{out}\n{err}"
    if "token too large" in text:
        return (
            "MONA cannot read the formula: a word of it (an atom name) is longer than the "
            "8,190 characters MONA reads ('token too large'); shorten its atom names (the "
            "progression engine reads names of any length)"
        )
    if "memory exhausted" in text:
        return (
            "MONA cannot read the formula: its parser takes a chain of at most about 3,300 "
            "operands of & or | ('memory exhausted' while reading it, not a lack of memory); "
            f"split it into several formulas ({SPLIT_ADVICE})"
        )
    if "out of memory" in text:
        return f"MONA ran out of memory (limit {memory_mb} MB): {TOO_MANY_STATES}"
    if returncode == -signal.SIGABRT:
        return (
            f"MONA aborted, as it does when its automaton outgrows its BDD table: {TOO_MANY_STATES}"
        )
    if returncode < 0:
        number = -returncode
        known = number in signal.Signals.__members__.values()
        return f"MONA was killed by {signal.Signals(number).name if known else f'signal {number}'}"
    detail = [line.strip() for line in text.splitlines() if line.strip()]
    return f"MONA failed (exit status {returncode}" + (f": {detail[-1]})" if detail else ")")


_FREE = re.compile(r"^DFA for formula with free variables:(.*)$", re.M)
_ACCEPTING = re.compile(r"^Accepting states:(.*)$", re.M)
_SIZE = re.compile(r"^Automaton has (\d+) states?", re.M)
_STATE = re.compile(r"^State (\d+): ([01X]*) -> state (\d+)\s*$", re.M)


def parse_output(text: str) -> MonaAutomaton:
    """Read MONA's `-w` output; MonaError when it is not there."""
    free, accepting, size = _FREE.search(text), _ACCEPTING.search(text), _SIZE.search(text)
    if not (free and accepting and size):
        raise MonaError("MONA printed no automaton")
    variables = tuple(v.lower() for v in free.group(1).split())
    transitions = tuple((int(s), cube, int(d)) for s, cube, d in _STATE.findall(text))
    if any(len(cube) != len(variables) for _, cube, _ in transitions):
        raise MonaError("MONA's transitions do not match its free variables")
    return MonaAutomaton(
        variables=variables,
        num_states=int(size.group(1)),
        accepting=frozenset(int(s) for s in accepting.group(1).split()),
        transitions=transitions,
    )


def automaton_to_dfa(mona: MonaAutomaton, alphabet: Alphabet) -> DFA:
    """MONA's automaton as a minimal tleaf DFA over `alphabet` (MONA's state 0 dropped)."""
    col = {a: k for k, a in enumerate(alphabet.atoms)}
    unknown = [v for v in mona.variables if v not in col]
    if unknown:
        raise MonaError(f"MONA reads variables {unknown} that the formula does not have")
    n_atoms = len(alphabet.atoms)
    src = np.array([t[0] for t in mona.transitions], dtype=np.int64)
    dst = np.array([t[2] for t in mona.transitions], dtype=np.int64)
    raw = "".join(t[1] for t in mona.transitions).encode("ascii")
    cubes = np.frombuffer(raw, dtype=np.uint8).reshape(len(src), len(mona.variables))
    care = np.zeros((len(src), n_atoms), dtype=bool)
    ones = np.zeros((len(src), n_atoms), dtype=bool)
    for j, var in enumerate(mona.variables):
        care[:, col[var]] = cubes[:, j] != ord("X")
        ones[:, col[var]] = cubes[:, j] == ord("1")
    table = np.full((mona.num_states, alphabet.size), -1, dtype=np.int64)
    if alphabet.kind == "powerset":
        rows, letters = _expand_cubes(care, ones)
        table[src[rows], letters] = dst[rows]
    else:
        _fill_one_hot(table, src, dst, care, ones)
    if (table < 0).any():
        raise MonaError("MONA's automaton is not complete over the alphabet")
    if (table[0] != table[0, 0]).any():
        raise MonaError("MONA's state 0 does not step to a single start state")
    accepting = np.zeros(mona.num_states, dtype=bool)
    accepting[list(mona.accepting)] = True
    start = int(table[0, 0])  # MONA's state 0 reads the encoding's extra first letter
    return DFA(alphabet, table, start, accepting).minimize_nonempty()


def _expand_cubes(care: np.ndarray, ones: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every (cube row, letter) pair the cubes cover, letters as powerset bitmasks.

    One atom at a time, each cube that leaves the atom free is split in two. MONA's cubes out of
    a state partition its letters, so the work is states x letters, not cubes x letters.
    """
    rows = np.arange(len(care))
    letters = (ones.astype(np.int64) << np.arange(care.shape[1])).sum(axis=1)
    free = ~care
    for k in range(care.shape[1]):
        split = free[rows, k]
        rows = np.concatenate([rows, rows[split]])
        letters = np.concatenate([letters, letters[split] | (1 << k)])
    return rows, letters


def _fill_one_hot(table, src, dst, care, ones) -> None:
    """Cube matches: the empty letter when it fixes no atom true; atom k when it fixes k true and
    no other, or fixes no atom true and leaves k free."""
    n_true = ones.sum(axis=1)
    empty = n_true == 0
    table[src[empty], 0] = dst[empty]
    atom = (empty[:, None] & ~care) | ((n_true == 1)[:, None] & ones)
    r, k = np.nonzero(atom)
    table[src[r], k + 1] = dst[r]
