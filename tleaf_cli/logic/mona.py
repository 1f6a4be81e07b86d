"""Running MONA safely and reading its automaton.

ltlf2dfa's `to_dfa()` writes one shared file inside site-packages and hides MONA's failures (see
DESIGN.md), so tleaf only borrows its MONA encoding (`MonaProgram`) and runs `mona -q -u -w` itself
in a private temporary directory, with a timeout and the exit status checked.

MONA's automaton reads one extra letter first (its state 0 steps to the real start on any letter);
each `State i: <cube> -> state j` line is a transition on every letter matching the cube, one
character per free variable (`0`, `1`, or `X` for either).
"""

from __future__ import annotations

import os
import re
import resource
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from functools import cache

import numpy as np
from ltlf2dfa.base import MonaProgram
from ltlf2dfa.ltlf import LTLfFormula

from tleaf_cli.logic.alphabet import Alphabet
from tleaf_cli.logic.dfa import DFA

INSTALL_HINT = "install it with: apt-get install -y mona  (Debian/Ubuntu package 'mona')"
DEFAULT_MEMORY_MB = 4096


class MonaError(RuntimeError):
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
    """ltlf2dfa's MONA encoding of an LTLf formula (header, declarations, formula)."""
    return MonaProgram(formula).mona_program()


def run_mona(program: str, timeout: float, memory_mb: int = DEFAULT_MEMORY_MB) -> str:
    """Run MONA on a program text in a private temp dir; its stdout, or MonaError.

    MONA's automata can grow exponentially (21 GB measured for a 22-step look-back), so its
    address space is capped at `memory_mb` as well as its time.
    """
    binary = mona_binary()
    limit = memory_mb * 1024 * 1024

    def cap_memory() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    with tempfile.TemporaryDirectory(prefix="tleaf-mona-") as tmp:
        path = os.path.join(tmp, "formula.mona")
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(program)
        try:
            proc = subprocess.run(
                [binary, "-q", "-u", "-w", path],
                capture_output=True,
                text=True,
                timeout=timeout,
                cwd=tmp,
                preexec_fn=cap_memory,
            )
        except subprocess.TimeoutExpired:
            raise MonaTimeout(f"MONA did not finish within {timeout:g} s") from None
    if proc.returncode != 0:
        detail = (proc.stderr or proc.stdout).strip().splitlines()
        reason = detail[-1] if detail else f"exit status {proc.returncode}"
        raise MonaError(f"MONA failed ({reason}; memory limit {memory_mb} MB)")
    return proc.stdout


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
    """MONA's automaton as a minimal tleaf DFA over `alphabet` (MONA's state 0 dropped).

    A transition's cube matches letter l when no variable it fixes disagrees with l; the
    disagreements for all cubes and letters are counted at once as a matrix product.
    """
    col = {a: k for k, a in enumerate(alphabet.atoms)}
    unknown = [v for v in mona.variables if v not in col]
    if unknown:
        raise MonaError(f"MONA reads variables {unknown} that the formula does not have")
    n_atoms = len(alphabet.atoms)
    care = np.zeros((len(mona.transitions), n_atoms), dtype=np.float32)
    value = np.zeros_like(care)
    for r, (_, cube, _) in enumerate(mona.transitions):
        for var, ch in zip(mona.variables, cube, strict=True):
            if ch != "X":
                care[r, col[var]] = 1.0
                value[r, col[var]] = 1.0 if ch == "1" else 0.0
    truth = alphabet.truth().astype(np.float32)  # [letters, atoms]
    # mismatches = sum_k care_k * (truth_k xor value_k)
    fixed_true = care * value
    mismatches = care @ truth.T + fixed_true.sum(1, keepdims=True) - 2 * fixed_true @ truth.T
    matches = mismatches < 0.5
    table = np.full((mona.num_states, alphabet.size), -1, dtype=np.int32)
    for r, (src, _, dst) in enumerate(mona.transitions):
        table[src, matches[r]] = dst
    if (table < 0).any():
        raise MonaError("MONA's automaton is not complete over the alphabet")
    accepting = np.zeros(mona.num_states, dtype=bool)
    accepting[list(mona.accepting)] = True
    if (table[0] != table[0, 0]).any():
        raise MonaError("MONA's state 0 does not step to a single start state")
    start = int(table[0, 0])  # MONA's state 0 reads the encoding's extra first letter
    return DFA(alphabet, table, start, accepting).minimize_nonempty()
