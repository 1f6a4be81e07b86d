"""Settings of the data stages: `tleaf compile-dfa` (`CompileSettings`), `tleaf gen-formulas`
(`FormulaSettings`) and `tleaf gen-traces` (`TraceSettings`). Pure Python: the command line
builds these commands' options from this module.

Where a run happens (parallel jobs, a cluster, the compile cache) is a plain field, not a setting:
it changes how fast a file is written, never what it holds.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from tleaf_cli.defaults import CANDIDATE_TIMEOUT, COMPILE_TIMEOUT, MAX_LEN, MIN_LEN
from tleaf_cli.errors import SettingError
from tleaf_cli.settings import setting

# A letter of a DFA's alphabet: a set of atoms (powerset) or one atom or none (one-hot);
# logic/alphabet.py's AlphabetKind.
ALPHABETS = ("powerset", "one-hot")
# How a formula becomes a DFA (logic/compile.py's ENGINES).
ENGINES = ("auto", "progression", "mona")
MAX_ATOMS = 26  # gen-formulas names its atoms a, b, c, ...
# How synthetic formulas and their traces are drawn: tleaf's tiers, or the authors' Table I
# protocol (data/paper_protocol.py).
PROTOCOLS = ("tleaf", "paper")
# What one arc of the automaton the paper protocol searches is: a whole guard, one cube of its
# irredundant sum of products, or one letter (data/paper_protocol.py says why guard).
PAPER_ARCS = ("guard", "cube", "letter")
PAPER_ARCS_HELP = (
    "With --protocol paper, what one arc of the searched automaton is, so what one accepting "
    "path is: guard (one per state and successor, as the authors' code reads its automata), "
    "cube (one per cube of the guard) or letter (one per letter). Give the same to "
    "gen-formulas and gen-traces."
)

SEED_HELP = "Random seed; the same seed writes the same file."


def default_cache_dir() -> Path:
    """$TLEAF_CACHE_DIR, else $XDG_CACHE_HOME/tleaf, else ~/.cache/tleaf."""
    if os.environ.get("TLEAF_CACHE_DIR"):
        return Path(os.environ["TLEAF_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "tleaf"


def fractions(text: str) -> tuple[float, float, float]:
    """train,val,test fractions as written on the command line ("0.8,0.1,0.1")."""
    try:
        parts = tuple(float(x) for x in text.split(","))
    except ValueError:
        parts = ()
    if len(parts) != 3:
        raise SettingError("split", f"takes three fractions like 0.8,0.1,0.1, not '{text}'")
    return parts  # type: ignore[return-value]


def _check_lengths(min_len: int, max_len: int) -> None:
    if not 1 <= min_len <= max_len:
        raise SettingError(
            "min_len", f"must be between 1 and the longest length ({max_len}), got {min_len}"
        )


@dataclass(frozen=True)
class CompileSettings:
    """How formulas become DFAs (compile-dfa, and every stage that compiles)."""

    alphabet: str = setting(
        "powerset",
        "One atom of the domain per step (one-hot): letters are single atoms or none; DFAs "
        "minimal over that alphabet, guards simplified under it. Else (powerset) a letter is "
        "any set of the atoms.",
        choices=ALPHABETS,
    )
    timeout: float = setting(
        COMPILE_TIMEOUT,
        "Seconds MONA may spend on one formula; past it, its row's error says so.",
        min=0.1,
    )
    engine: str = setting(
        "auto",
        "auto: build the DFA in this process by formula progression, and hand a formula to "
        "MONA when that passes its limits (2,000 states; 20,000 units of work, about 10 ms, in "
        "one construction: counted, not timed, so a formula takes the same route under any "
        "load); progression: never MONA (such formulas fail past 2,000 states or 3,000,000 "
        "units, their row's error says so); mona: MONA for every formula. All give the same "
        "minimal DFA.",
        choices=ENGINES,
    )
    cache_dir: Path | None = field(default_factory=default_cache_dir)  # None: no cache
    jobs: int = 1
    cluster: str | None = None  # a dask scheduler address: run there instead (data/parallel.py)


@dataclass(frozen=True)
class FormulaSettings:
    """Which random formulas gen-formulas draws and keeps (recorded in the file's header)."""

    n: int = setting(100, "Formulas to keep.", min=1)
    atoms: int = setting(3, "Distinct atoms in every formula (a, b, c, ...).")
    size: int = setting(10, "Syntax-tree nodes (operators + atom occurrences).")
    seed: int = setting(0, SEED_HELP)
    min_len: int = setting(MIN_LEN, "Shortest trace length.", min=1)
    max_len: int = setting(MAX_LEN, "Longest trace length.", min=1)
    pairs: int = setting(
        20,
        "Keep formulas with at least this many distinct (satisfying, violating) pairs of equal "
        "length: gen-traces' --per-formula.",
        min=1,
    )
    one_hot: bool = setting(False, "Judge formulas on one-hot traces.")
    protocol: str = setting(
        "tleaf",
        "tleaf: every atom in, every operator, kept if new in language with --pairs pairs at "
        "lengths --min-len to --max-len; paper: the authors' Table I data (spot randltl's tree of "
        "--size over true false ! X F G & | U, atoms optional, new in text, at most 20 "
        "states, at least 5 accepting paths, a rejected word within 40 letters).",
        choices=PROTOCOLS,
    )
    paper_arcs: str = setting("guard", PAPER_ARCS_HELP, choices=PAPER_ARCS)
    prefix: str = setting(
        "f", "Formula id prefix: ASCII letters, digits, _ . - (with --tier: the tier and a dash)."
    )
    timeout: float = setting(
        CANDIDATE_TIMEOUT, "MONA seconds per candidate; slower ones are rejected.", min=0.001
    )
    cache_dir: Path | None = field(default_factory=default_cache_dir)  # None: no cache
    jobs: int = 1
    cluster: str | None = None

    def check(self) -> None:
        """SettingError for settings no draw can satisfy (the prefix is checked where the ids
        are made, data/formula_gen.py)."""
        if not 1 <= self.atoms <= MAX_ATOMS:
            raise SettingError("atoms", f"must be 1..{MAX_ATOMS}, got {self.atoms}")
        if self.protocol == "tleaf" and self.size < 2 * self.atoms - 1:
            raise SettingError(
                "size",
                f"{self.size} cannot hold {self.atoms} distinct atoms "
                "(a tree with k leaves has at least 2k-1 nodes)",
            )
        if self.n < 1:
            raise SettingError("n", f"must be at least 1, got {self.n}")
        _check_lengths(self.min_len, self.max_len)


@dataclass(frozen=True)
class TraceSettings:
    """Which traces gen-traces draws for every DFA."""

    per_formula: int = setting(20, "K: satisfying and K violating traces per formula.", min=1)
    min_len: int = setting(MIN_LEN, "Shortest trace length.", min=1)
    max_len: int = setting(MAX_LEN, "Longest trace length.", min=1)
    hard_fraction: float = setting(0.5, "Share of violating traces that are hard negatives.")
    one_hot: bool = setting(False, "One-hot letters only (a single atom, or none).")
    once_each: bool = setting(
        False,
        "Traces that read every atom of the formula exactly once (plus 0..--max-none 'none' "
        "steps), like a labelled video under its own rule set; implies --one-hot letters; "
        "ignores --min-len, --max-len, --hard-fraction.",
    )
    max_none: int = setting(
        3,
        "With --once-each: at most this many 'none' steps (other pairs of the video; more for "
        "per-ingredient rule sets).",
        min=0,
    )
    protocol: str = setting(
        "tleaf",
        "tleaf: K length-matched pairs as above; paper: the authors' Table I traces (up to 10 "
        "simple accepting paths, each letter a random completion of a disjunct of its guard, "
        "the set three times; each paired with a uniform rejected word of its length); "
        "ignores --per-formula, --min-len, --max-len, --hard-fraction.",
        choices=PROTOCOLS,
    )
    paper_arcs: str = setting("guard", PAPER_ARCS_HELP, choices=PAPER_ARCS)
    paper_hard: float = setting(
        0.0,
        "With --protocol paper: the share of the authors' positives whose violating trace is "
        "a hard negative (as --hard-fraction; the authors' protocol: 0, every one uniform).",
    )
    split: tuple[float, float, float] | None = setting(
        None,
        "Add a split column by formula: train,val,test fractions.",
        auto="none: no split column",
        parse=fractions,
    )
    seed: int = setting(0, SEED_HELP)
    jobs: int = 1
    cluster: str | None = None  # a dask scheduler address: run there instead (data/parallel.py)

    def check(self) -> None:
        _check_lengths(self.min_len, self.max_len)
        for name in ("hard_fraction", "paper_hard"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise SettingError(name, f"must be in [0, 1], got {getattr(self, name)}")
        if self.per_formula < 1:
            raise SettingError("per_formula", f"must be at least 1, got {self.per_formula}")
        if self.max_none < 0:
            raise SettingError("max_none", f"must be >= 0, got {self.max_none}")
        if self.split is not None and (
            len(self.split) != 3 or min(self.split) < 0 or abs(sum(self.split) - 1) > 1e-6
        ):
            raise SettingError(
                "split", f"must be three non-negative fractions summing to 1, not {self.split}"
            )
