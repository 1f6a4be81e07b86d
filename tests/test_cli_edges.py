"""Command-line edges, one test (or two) per case: a byte-order mark at the start of a `.ltl` file,
invisible characters in error lines, MONA's failures told by their cause, a damaged Parquet file
named in `inspect`'s error, upper-case argument names in usage lines, no pydantic "Value error, "
in a refused value, docs/decoding.md describing the cooking shield as it is, and the entry point's
garbage collector settings."""

from __future__ import annotations

import gc
import re
import sys
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from tleaf_cli import cli
from tleaf_cli.data.dfa_table import read_dfas
from tleaf_cli.knowledge.base import read_knowledge_base
from tleaf_cli.logic import mona
from tleaf_cli.logic.formulas import parse
from tleaf_cli.ui import visible

runner = CliRunner()
DOCS = Path(__file__).parent.parent / "docs"
BOM = b"\xef\xbb\xbf"
TOO_MANY_STATES = (
    "the formula has too many states for MONA; split it into smaller formulas (a conjunction "
    "into one formula per conjunct) or give each fewer eventualities (F, U)"
)


def tleaf(*args):
    return runner.invoke(cli.app, [str(a) for a in args])


def _errors(output: str) -> list[str]:
    """The `error:` lines of an output."""
    return [line for line in output.splitlines() if line.startswith("error:")]


def _flat(text: str) -> str:
    """Rich's error box without its frame and line wrapping: words separated by single spaces."""
    return " ".join(re.sub(r"[│╭╮╰╯─]", " ", text).split())


# 1. A byte-order mark (Notepad writes one) is not part of the first line.


def test_a_formula_file_with_a_byte_order_mark_keeps_its_first_rule(tmp_path: Path) -> None:
    source, out = tmp_path / "bom.ltl", tmp_path / "dfas.parquet"
    source.write_bytes(BOM + b"rinse: F rinse\ncook: F cook\n")
    result = tleaf("compile-dfa", source, "-o", out, "--no-cache")
    assert result.exit_code == 0, result.output
    assert _errors(result.output) == []
    assert "2 of 2 formulas compiled" in result.output
    assert read_dfas(out).ids() == ["rinse", "cook"]


def test_a_knowledge_base_with_a_byte_order_mark_keeps_its_first_rule(tmp_path: Path) -> None:
    path = tmp_path / "kb.ltl"
    path.write_bytes(BOM + b"affordance.rinse_cabbage: F rinse_cabbage\n")
    assert [rule.name for rule in read_knowledge_base(path).rules] == ["affordance.rinse_cabbage"]


def test_bytes_that_are_not_utf8_are_counted_from_the_file_start(tmp_path: Path) -> None:
    source = tmp_path / "bad.ltl"
    source.write_bytes(BOM + b"ab\xff\n")
    result = tleaf("compile-dfa", source, "-o", tmp_path / "dfas.parquet")
    assert result.exit_code == 2
    assert _errors(result.output) == [f"error: {source}: not UTF-8 text (byte 5)"]


# 2. Invisible characters in error lines are shown escaped; letters in any script are not.


def test_visible_escapes_what_does_not_show_and_keeps_letters() -> None:
    assert visible("\ufeffrinse") == "\\ufeffrinse"
    assert visible("a\x00b\u200bc\td\xa0e\nf") == "a\\x00b\\u200bc\\td\\xa0e\\nf"
    assert visible("γ é 'x' \\ [ok]") == "γ é 'x' \\ [ok]"


def test_failure_lines_show_invisible_characters_escaped(tmp_path: Path) -> None:
    source = tmp_path / "f.ltl"
    source.write_text("ri\u200bnse: F rinse\nγ\x00: F cook\nok: F serve\n", encoding="utf-8")
    result = tleaf("compile-dfa", source, "-o", tmp_path / "dfas.parquet", "--no-cache")
    assert result.exit_code == 1
    allowed = "(allowed: ASCII letters, digits, _ . -)"
    assert _errors(result.output) == [
        f"error: {source}: line 1: invalid formula name 'ri\\u200bnse' {allowed}",
        f"error: {source}: line 2: invalid formula name 'γ\\x00' {allowed}",
    ]


def test_a_fatal_line_shows_invisible_characters_escaped(tmp_path: Path) -> None:
    missing = tmp_path / "rules\ufeffé.ltl"
    result = tleaf("compile-dfa", missing, "-o", tmp_path / "dfas.parquet")
    assert result.exit_code == 2
    assert _errors(result.output) == [f"error: {tmp_path}/rules\\ufeffé.ltl: no such file"]


# 3. MONA's failures by their cause, with what to do, one line per failed row.


def test_a_formula_longer_than_monas_reader_takes_compiles(tmp_path: Path) -> None:
    """60,000 characters: ltlf2dfa's encoding starts with the formula as a comment, one MONA
    token, which MONA refused ("token too large") past 8,190 characters."""
    source, out = tmp_path / "long.ltl", tmp_path / "dfas.parquet"
    long = " | ".join(["(a & b)"] * 6001)
    source.write_text(f"long: {long}\nshort: a & b\n", encoding="utf-8")
    assert len(long) > 60_000
    # A timeout far past what it needs (1.6 s of CPU; 5 s of wall time measured on two busy cores)
    # so that no load on the machine decides the test.
    result = tleaf("compile-dfa", source, "-o", out, "--engine", "mona", "--timeout", 300)
    assert result.exit_code == 0, result.output
    assert "2 of 2 formulas compiled" in result.output
    table = read_dfas(out)
    same = ("num_states", "initial", "accepting", "edges")
    assert [table.row("long")[k] for k in same] == [table.row("short")[k] for k in same]


def test_an_atom_name_longer_than_mona_reads_says_so(tmp_path: Path) -> None:
    source = tmp_path / "atom.ltl"
    source.write_text(f"long: F a{'x' * 9000}\n", encoding="utf-8")
    result = tleaf("compile-dfa", source, "-o", tmp_path / "d.parquet", "--engine", "mona")
    assert result.exit_code == 1
    assert _errors(result.output) == [
        f"error: {source}: line 1: MONA cannot read the formula: a word of it (an atom name) is "
        "longer than the 8,190 characters MONA reads ('token too large'); shorten its atom "
        "names (the progression engine reads names of any length)"
    ]


def test_a_state_explosion_is_told_as_one(tmp_path: Path) -> None:
    """20 eventualities over one-hot letters: 2^20 states; MONA aborts (its BDD table) in about
    2.5 s on an idle machine (13.5 s measured on two busy cores), far within the timeout."""
    source = tmp_path / "many.ltl"
    source.write_text(
        "many: " + " & ".join(f"F a{k}" for k in range(1, 21)) + "\nfew: F a1 & F a2\n",
        encoding="utf-8",
    )
    args = ["-o", tmp_path / "d.parquet", "--one-hot", "--engine", "mona", "--timeout", 300]
    result = tleaf("compile-dfa", source, *args, "--no-cache")
    assert result.exit_code == 1
    assert _errors(result.output) == [
        f"error: {source}: line 1: MONA aborted, as it does when its automaton outgrows its BDD "
        f"table: {TOO_MANY_STATES}"
    ]
    assert "1 of 2 formulas compiled" in result.output


def test_running_out_of_memory_is_told_with_the_limit() -> None:
    program = mona.mona_program(parse(" & ".join(f"F a{k}" for k in range(1, 17))))
    with pytest.raises(mona.MonaError) as caught:
        mona.run_mona(program, timeout=300, memory_mb=100)  # the memory cap, not the clock
    assert str(caught.value) == f"MONA ran out of memory (limit 100 MB): {TOO_MANY_STATES}"


# 4. `inspect` names a damaged Parquet file in its one-line error.


@pytest.fixture
def damaged(tmp_path: Path) -> Path:
    """A dfas.parquet whose footer reads but whose first data page is overwritten."""
    source, path = tmp_path / "f.ltl", tmp_path / "damaged.parquet"
    source.write_text("rinse: F rinse\ncook: F cook\n", encoding="utf-8")
    assert tleaf("compile-dfa", source, "-o", path, "-q").exit_code == 0
    data = bytearray(path.read_bytes())
    data[4:64] = b"A" * 60
    path.write_bytes(bytes(data))
    return path


@pytest.mark.parametrize("options", [[], ["--stats"], ["--id", "rinse"]], ids=str)
def test_inspect_names_a_damaged_file(damaged: Path, options: list[str]) -> None:
    result = tleaf("inspect", *options, damaged)
    assert result.exit_code == 2
    assert result.stdout == ""  # nothing of the file printed before its error
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {damaged}: unreadable ("), lines


@pytest.mark.parametrize(
    ("content", "detail"),
    [
        (b"formula_id,formula\nL1,F a\n" * 10, "Parquet magic bytes not found in footer"),
        (b"hello\n", "Parquet file size is 6 bytes"),
    ],
    ids=["text", "tiny"],
)
def test_inspect_names_a_file_that_is_not_parquet(tmp_path: Path, content, detail) -> None:
    path = tmp_path / "x.parquet"
    path.write_bytes(content)
    result = tleaf("inspect", path)
    assert result.exit_code == 2
    [line] = _errors(result.output)
    assert line.startswith(f"error: {path}: not a Parquet file ({detail}")


# 5. Positional arguments show as upper-case names.


def _commands() -> list[tuple[list[str], object]]:
    found, stack = [], [([], typer.main.get_command(cli.app))]
    while stack:
        path, command = stack.pop()
        found.append((path, command))
        stack.extend(([*path, name], sub) for name, sub in getattr(command, "commands", {}).items())
    return sorted(found, key=lambda item: item[0])


def test_usage_lines_show_upper_case_arguments() -> None:
    usage = {}
    for path, _ in _commands():
        result = tleaf(*path, "--help")
        assert result.exit_code == 0, path
        [line] = [line.strip() for line in result.output.splitlines() if "Usage:" in line]
        usage[" ".join(path)] = line
        assert "{" not in line, line
    assert usage["compile-dfa"] == "Usage: tleaf compile-dfa [OPTIONS] FORMULAS"
    assert usage["eval model-checking"] == "Usage: tleaf eval model-checking [OPTIONS] DFAS TRACES"
    assert usage["eval table"] == "Usage: tleaf eval table [OPTIONS] REPORTS..."
    assert usage["inspect"] == "Usage: tleaf inspect [OPTIONS] PATH"
    assert usage["eval"] == "Usage: tleaf eval [OPTIONS] COMMAND [ARGS]..."


def test_the_arguments_panel_and_a_missing_argument_use_the_same_name() -> None:
    help_text = tleaf("compile-dfa", "--help").output
    assert re.search(r"│ \*\s+FORMULAS\s+<path>", help_text), help_text
    result = tleaf("compile-dfa")
    assert result.exit_code == 2
    assert result.output.splitlines()[0] == "Usage: tleaf compile-dfa [OPTIONS] FORMULAS"
    assert "Missing argument 'FORMULAS'." in _flat(result.output)


# 6. A value outside a fixed set is refused in click's words, without pydantic's prefix.


def test_a_refused_choice_has_no_value_error_prefix(tmp_path: Path) -> None:
    result = tleaf("gen-formulas", "--tier", "extreme", "-o", tmp_path / "x.ltl")
    assert result.exit_code == 2
    assert (
        "Invalid value for '--tier': 'extreme' is not one of 'low', 'moderate', 'high'."
        in _flat(result.output)
    )
    assert "Value error" not in result.output
    assert not (tmp_path / "x.ltl").exists()


# 7. docs/decoding.md describes the cooking shield as built and measured.


def test_decoding_doc_describes_the_cooking_shield_as_it_is() -> None:
    """Built (`train-task cooking --shield`, tasks/cooking/shield.py: one `tl.Shield` following one
    rule set per rule) and measured (docs/results/cooking.md)."""
    text = " ".join((DOCS / "decoding.md").read_text(encoding="utf-8").split())
    for unfinished in ("not done", "not yet", "not built", "TODO", "planned"):
        assert unfinished not in text, unfinished
    assert (
        "`tleaf train-task cooking --shield` trains GAIL's policy under the shield of the "
        "episode's knowledge-base rules (`tasks/cooking/shield.py`: one `tl.Shield` over one "
        "rule set per rule;" in text
    )
    results = (DOCS / "results" / "cooking.md").read_text(encoding="utf-8")
    assert "| shield | 5 | demonstrated | **5 of 5** |" in results
    assert "at 5 of 5 seeds" in text
    assert "−58.58 against −87.59" in text and "(−58.58 against −87.59 at the end)" in results
    assert "--shield" in _flat(tleaf("train-task", "cooking", "--help").output)
    source = (DOCS.parent / "tleaf_cli" / "tasks" / "cooking" / "shield.py").read_text()
    assert "return Shield([RuleSet(" in source


def _full_collections() -> int:
    """Full collections while long-lived containers are built (as importing torch and reading a
    run's data build them): as many as the process has, at least 200,000; Python's defaults take
    a full collection once they have grown by a quarter (and 70,000 allocations have passed)."""
    count = [0]

    def seen(phase: str, info: dict) -> None:
        count[0] += phase == "stop" and info["generation"] == 2

    gc.collect()
    gc.callbacks.append(seen)
    try:
        kept = [[i] for i in range(max(200_000, len(gc.get_objects())))]
    finally:
        gc.callbacks.remove(seen)
    del kept
    return count[0]


def test_the_entry_point_spares_full_collections_while_a_command_builds(monkeypatch) -> None:
    before = gc.get_threshold()
    monkeypatch.setattr(sys, "argv", ["tleaf", "--version"])
    try:
        gc.set_threshold(700, 10, 10)  # Python's defaults: the same build takes full collections
        assert _full_collections() > 0
        with pytest.raises(SystemExit):
            cli.main()
        assert _full_collections() == 0
    finally:
        gc.set_threshold(*before)
