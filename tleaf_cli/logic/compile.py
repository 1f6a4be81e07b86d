"""LTLf formula text to a minimal DFA: parse, encode for MONA, run it, read back, minimise."""

from __future__ import annotations

from tleaf_cli.logic.alphabet import Alphabet, AlphabetKind
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.formulas import atoms, parse
from tleaf_cli.logic.mona import automaton_to_dfa, mona_program, parse_output, run_mona

DEFAULT_TIMEOUT = 30.0


def compile_formula(
    text: str, alphabet: AlphabetKind = "powerset", timeout: float = DEFAULT_TIMEOUT
) -> DFA:
    """The minimal DFA accepting exactly the non-empty traces that satisfy `text`.

    Raises FormulaSyntaxError, LetterError (too many atoms for a powerset alphabet) or MonaError.
    """
    formula = parse(text)
    letters = Alphabet(atoms(formula), alphabet)
    output = run_mona(mona_program(formula), timeout)
    return automaton_to_dfa(parse_output(output), letters)
