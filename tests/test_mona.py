"""MONA's route (`logic/mona.py`): encodings too large to write are refused before MONA runs, and
each way MONA fails is told by its cause with what to do about it."""

from __future__ import annotations

import shutil

import pytest

from tleaf_cli.logic import mona
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.logic.formulas import parse

needs_mona = pytest.mark.skipif(shutil.which("mona") is None, reason="needs MONA")

# What MONA 1.4 prints when its parser's stack fills up (stdout, exit status 255).
PARSER_FULL = "Error in file 'formula.mona' near line 3: memory exhausted\nExecution aborted\n"


def test_an_encoding_that_doubles_per_level_is_refused_before_it_is_written() -> None:
    """20 nested G make a 185 MB MONA program; 25 exhausted the memory writing it."""
    with pytest.raises(mona.MonaError, match="too large for MONA"):
        mona.mona_program(parse("G (" * 25 + "a" + ")" * 25))
    nested_f = parse("F (" * 25 + "a" + ")" * 25)  # F writes its operand once: fine
    assert mona.encoding_nodes(nested_f) < 100


def test_a_full_parser_stack_is_told_as_a_chain_too_long_with_the_split_advice() -> None:
    """MONA's last line, "Execution aborted", says nothing; the line before says why."""
    reason = mona.failure_reason(255, PARSER_FULL, "", mona.DEFAULT_MEMORY_MB)
    assert "exit status 255" not in reason
    assert "chain of at most about 3,300 operands of & or |" in reason
    assert "one formula per conjunct" in reason and "not a lack of memory" in reason


@needs_mona
def test_a_conjunction_longer_than_monas_parser_reads_fails_with_cause_and_advice() -> None:
    """3,400 conjuncts (34,000 characters) through MONA: its parser holds at most 3,331 operands
    of one chain; the error gives that cause and the split, as shorter failures do."""
    text = " & ".join(f"a{i}" for i in range(3400))
    with pytest.raises(mona.MonaError) as caught:
        compile_formula(text, "one-hot", engine="mona")
    message = str(caught.value)
    assert "chain of at most about 3,300 operands" in message, message
    assert "one formula per conjunct" in message


@needs_mona
def test_a_chain_within_the_parsers_reach_compiles_through_mona() -> None:
    text = " & ".join(f"G !a{i}" for i in range(300))
    dfa = compile_formula(text, "one-hot", engine="mona")
    assert dfa.num_states == 2  # never one of the atoms: one live state and the sink
