"""LTLf formula text to a minimal DFA: parse, encode for MONA, run it, read back, minimise."""

from __future__ import annotations

from tleaf_cli.logic import mona
from tleaf_cli.logic.alphabet import Alphabet, AlphabetKind
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.formulas import atoms, parse

DEFAULT_TIMEOUT = 30.0


def compile_formula(
    text: str, alphabet: AlphabetKind = "powerset", timeout: float = DEFAULT_TIMEOUT
) -> DFA:
    """The minimal DFA accepting exactly the non-empty traces that satisfy `text`.

    Raises FormulaSyntaxError, LetterError (too many atoms for a powerset alphabet) or MonaError.
    """
    formula = parse(text)
    letters = Alphabet(atoms(formula), alphabet)
    output = mona.run_mona(mona.mona_program(formula), timeout)
    return mona.automaton_to_dfa(mona.parse_output(output), letters)
