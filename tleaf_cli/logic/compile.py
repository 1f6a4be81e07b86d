"""LTLf formula text to a minimal DFA: parse, encode for MONA, run it, read back, minimise."""

from __future__ import annotations

from ltlf2dfa.ltlf import LTLfFormula

from tleaf_cli.defaults import COMPILE_TIMEOUT
from tleaf_cli.logic import mona
from tleaf_cli.logic.alphabet import Alphabet, AlphabetKind
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.formulas import atoms, parse


def compile_formula(
    text: str, alphabet: AlphabetKind = "powerset", timeout: float = COMPILE_TIMEOUT
) -> DFA:
    """The minimal DFA accepting exactly the non-empty traces that satisfy `text`.

    Raises FormulaSyntaxError, LetterError (too many atoms for a powerset alphabet) or MonaError.
    """
    return compile_parsed(parse(text), alphabet, timeout)


def compile_parsed(
    formula: LTLfFormula, alphabet: AlphabetKind = "powerset", timeout: float = COMPILE_TIMEOUT
) -> DFA:
    """`compile_formula` for a formula already parsed."""
    letters = Alphabet(atoms(formula), alphabet)
    output = mona.run_mona(mona.mona_program(formula), timeout)
    return mona.automaton_to_dfa(mona.parse_output(output), letters)
