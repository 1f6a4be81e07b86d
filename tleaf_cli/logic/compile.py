"""LTLf formula text to a minimal DFA: in this process by progression where that is quick, else by
MONA (parse, encode, run it, read back), minimised either way.

Both routes end in the same canonical minimal DFA (`DFA.minimize` numbers states the same way for
one language), so which one compiled a formula never shows in the result; the tests compare them
formula by formula. `engine` picks the route: "auto" (progression, MONA when progression passes
its limits), "progression" (never MONA: past the limits the formula fails), or "mona".
"""

from __future__ import annotations

from typing import Literal

from ltlf2dfa.ltlf import LTLfFormula

from tleaf_cli import arguments
from tleaf_cli.defaults import COMPILE_TIMEOUT
from tleaf_cli.errors import SettingError
from tleaf_cli.logic import mona
from tleaf_cli.logic.alphabet import Alphabet, AlphabetKind
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.formulas import atoms, parse
from tleaf_cli.logic.progression import Limits, TooLarge, progression_dfa

Engine = Literal["auto", "progression", "mona"]
ENGINES: tuple[Engine, ...] = ("auto", "progression", "mona")
# Under "auto", one direct progression may do this much work (progression's units, counted, not
# timed) before MONA takes the formula over: about 10 ms of CPU on the benchmark machine (0.5 µs a
# unit), twice what MONA needs for a small formula (5 ms), so progression is used where it is the
# quicker route, and a rare formula whose DNF states blow up, which would take seconds, goes to
# MONA. Counted, the choice is the same for a formula on any machine under any load; how it was
# chosen: benchmarks/progression_work.py, docs/benchmarks.md.
AUTO_WORK = 20_000


def compile_formula(
    text: str,
    alphabet: AlphabetKind = "powerset",
    timeout: float = COMPILE_TIMEOUT,
    engine: Engine = "auto",
) -> DFA:
    """The minimal DFA accepting exactly the non-empty traces that satisfy `text`.

    Raises ArgumentTypeError for a `text` that is not a str, FormulaSyntaxError, LetterError (too
    many atoms for a powerset alphabet), MonaError, or TooLarge (engine "progression" only).
    """
    return compile_parsed(parse(arguments.text(text, "text")), alphabet, timeout, engine)


def compile_parsed(
    formula: LTLfFormula,
    alphabet: AlphabetKind = "powerset",
    timeout: float = COMPILE_TIMEOUT,
    engine: Engine = "auto",
) -> DFA:
    """`compile_formula` for a formula already parsed. `timeout` bounds MONA only; progression is
    bounded by its state and work limits (progression.Limits), and under "auto" by AUTO_WORK
    units of work per direct construction, past which MONA is the quicker route."""
    dfa = by_progression(formula, alphabet, engine)
    return dfa if dfa is not None else by_mona(formula, alphabet, timeout)


def by_progression(formula: LTLfFormula, alphabet: AlphabetKind, engine: Engine) -> DFA | None:
    """The engine's progression step: the DFA, or None when MONA should compile the formula
    (engine "mona", or "auto" past progression's limits); TooLarge under "progression"."""
    if engine not in ENGINES:
        raise SettingError("engine", f"must be one of {', '.join(ENGINES)}, not {engine!r}")
    if engine == "mona":
        return None
    limits = Limits(max_direct_work=AUTO_WORK if engine == "auto" else None)
    try:
        return progression_dfa(formula, Alphabet(atoms(formula), alphabet), limits)
    except TooLarge:
        if engine == "progression":
            raise
        return None


def by_mona(formula: LTLfFormula, alphabet: AlphabetKind, timeout: float = COMPILE_TIMEOUT) -> DFA:
    """The DFA through MONA: ltlf2dfa's encoding, run and read back by tleaf (mona.py)."""
    output = mona.run_mona(mona.mona_program(formula), timeout)
    return mona.automaton_to_dfa(mona.parse_output(output), Alphabet(atoms(formula), alphabet))
