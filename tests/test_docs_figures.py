"""Each headline figure has one source, a results page's table (or the sentence of a results page
that states it), and every copy in README.md and docs/ is checked against it: a re-measured
table whose copies were not updated fails here.

A quote is a template with `{}` slots; the slots are filled from the source cells (formatted as
the quote writes them: as in the table, or rounded), and the filled text must occur in the
quoting page, whitespace and bold markers ignored (a quote may wrap across lines).
"""

from __future__ import annotations

import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).parent.parent
RESULTS = ROOT / "docs" / "results"


@dataclass(frozen=True)
class Table:
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]

    def row(self, *keys: str) -> dict[str, str]:
        """The first row whose leading cells are `keys`, as {column: cell}."""
        for row in self.rows:
            if row[: len(keys)] == keys:
                return dict(zip(self.header, row, strict=True))
        raise LookupError(f"no row {keys} in the table {self.header}")

    def column(self, name: str) -> list[str]:
        i = self.header.index(name)
        return [row[i] for row in self.rows]


def _cells(line: str) -> tuple[str, ...]:
    return tuple(c.strip().replace("**", "") for c in line.strip().strip("|").split("|"))


@cache
def tables(page: Path) -> tuple[Table, ...]:
    """Every Markdown table of a page, bold markers dropped from its cells."""
    out, lines = [], page.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        if lines[i].startswith("|") and i + 1 < len(lines) and lines[i + 1].startswith("|---"):
            header, body = _cells(lines[i]), []
            i += 2
            while i < len(lines) and lines[i].startswith("|"):
                body.append(_cells(lines[i]))
                i += 1
            out.append(Table(header, tuple(body)))
        else:
            i += 1
    return tuple(out)


def table(page: str, *columns: str) -> Table:
    """The first table of docs/results/`page` whose header holds every one of `columns`."""
    for t in tables(RESULTS / page):
        if all(c in t.header for c in columns):
            return t
    raise LookupError(f"{page}: no table with the columns {columns}")


def sentence(page: str, pattern: str) -> str:
    """The first group of `pattern` in docs/results/`page` (whitespace and bold normalised)."""
    match = re.search(pattern, _normal((RESULTS / page).read_text(encoding="utf-8")))
    assert match, f"{page}: no sentence matches {pattern!r}"
    return match.group(1)


def mean(cell: str) -> str:
    """'90.42 ± 0.22' -> '90.42'; '+2.55 %' -> '+2.55'; '64.00%' -> '64.00'."""
    return cell.split("±")[0].replace("%", "").strip()


def number(text: str) -> float:
    return float(mean(text).replace("−", "-").replace("×", "").replace(",", ""))


def rounded(cell: str, digits: int) -> str:
    """A cell's mean rounded as a quote writes it, its sign and minus sign kept."""
    value = number(cell)
    text = f"{abs(value):.{digits}f}"
    raw = mean(cell)
    if value < 0:
        return ("−" if "−" in raw else "-") + text
    return ("+" if raw.startswith("+") else "") + text


def _normal(text: str) -> str:
    return " ".join(text.replace("**", "").split())


@dataclass(frozen=True)
class Quote:
    page: str  # relative to the repository
    template: str
    values: Callable[[], list[str]]


# --- the sources -----------------------------------------------------------------------------


def table1(embedder: str, classifier: str, digits: int | None = None) -> Callable[[], list[str]]:
    def values() -> list[str]:
        row = table("model_checking.md", "embedder", "Low").row(embedder, classifier)
        cells = [row["Low"], row["Moderate"], row["High"]]
        return [mean(c) if digits is None else rounded(c, digits) for c in cells]

    return values


BEST = table1("DFA, `--preset best`", "MLP 512-128, data seed 0")
PAPER_PRESET = table1("DFA, `--preset paper`", "MLP 512-128, data seed 0")
PAPER_PRESET_1 = table1("DFA, `--preset paper`", "MLP 512-128, data seed 0", digits=1)
PAPERS = table1("paper: DFA (T-LEAF)", "MLP")


def table1_gap(minus: Callable[[], list[str]], of: list[float] | None = None):
    """Points between Table I's cells, rounded to whole points (`minus` from the best row) or,
    with `of`, to tenths (the best row short of the targets `of`)."""

    def values() -> list[str]:
        if of is None:
            return [f"+{number(b) - number(m):.0f}" for b, m in zip(BEST(), minus(), strict=True)]
        return [f"{t - number(b):.1f}" for t, b in zip(of, minus(), strict=True)]

    return values


def evidence_parts() -> list[str]:
    t = table("model_checking.md", "the block alone", "the learned part alone")
    low, high = t.row("0, Low"), t.row("0, High")
    return [
        low["the block alone"],
        high["the block alone"],
        low["the learned part alone"],
        high["the learned part alone"],
    ]


def fig4b(*cells: tuple[str, str]) -> Callable[[], list[str]]:
    """Δ action of (model, loss prefix) rows of the 60-video table."""

    def values() -> list[str]:
        t = table("action_recognition.md", "model", "loss", "Δ action", "improved")
        out = []
        for model, loss in cells:
            row = next(r for r in t.rows if r[0] == model and r[1].startswith(loss))
            out.append(mean(dict(zip(t.header, row, strict=True))["Δ action"]))
        return out

    return values


def decoding_table() -> Table:
    return table("action_recognition.md", "action acc constrained", "violations argmax")


def violations_range() -> list[str]:
    shares = [number(c) for c in decoding_table().column("violations argmax")]
    return [str(round(min(shares))), str(round(max(shares)))]


def decoding_gain_range() -> list[str]:
    gains = decoding_table().column("Δ action")
    low, high = min(gains, key=number), max(gains, key=number)
    return [rounded(low, 1), rounded(high, 1)]


def decoding_gain(*models: str) -> Callable[[], list[str]]:
    def values() -> list[str]:
        t = decoding_table()
        return [rounded(t.row(m, "none")["Δ action"], 1).lstrip("+") for m in models]

    return values


def curve_rows() -> Table:
    return table("learning_curve.md", "videos", "variant", "Δ action (%)", "data worth")


def curve(videos: str, variant: str, digits: int | None = None) -> Callable[[], list[str]]:
    def values() -> list[str]:
        cell = curve_rows().row(videos, variant)["Δ action (%)"]
        return [mean(cell) if digits is None else rounded(cell, digits)]

    return values


def most_data_worth() -> list[str]:
    worth = [c for c in curve_rows().column("data worth") if re.fullmatch(r"[\d.]+×", c)]
    return [max(worth, key=number)]


def cooking_held_out_end(*variants: str) -> list[str]:
    t = table("cooking.md", "variant", "pool", "return at 25 / 50 / 100 % of budget")
    out = []
    for variant in variants:
        row = next(r for r in t.rows if r[0].startswith(variant) and r[2] == "held-out")
        end = dict(zip(t.header, row, strict=True))["return at 25 / 50 / 100 % of budget"]
        out.append(rounded(end.split(" / ")[-1], 0))
    return out


def cooking_ratio() -> list[str]:
    return [sentence("cooking.md", r"tleaf / reference median steps to 90 % is ([\d.]+)")]


def other_configuration() -> list[str]:
    return [
        sentence("learning_curve.md", r"the exact loss lowered action accuracy: (\S+) % at 20"),
        sentence("learning_curve.md", r"rules still helped there: (\S+) % at 20"),
    ]


# --- the quotes ------------------------------------------------------------------------------

QUOTES = [
    Quote("README.md", "(`--preset best`) scores {} / {} / {} (Low / Moderate / High)", BEST),
    Quote("docs/embedder.md", "`best` scores {} / {} / {} (Low / Moderate / High", BEST),
    Quote("docs/how-it-works.md", "the default q scores {} / {} / {} (Low / Moderate", BEST),
    Quote("README.md", "(`--preset paper`) scores {} / {} / {}.", PAPER_PRESET),
    Quote("docs/embedder.md", "and `paper` {} / {} / {} —", PAPER_PRESET),
    Quote("docs/results/model_checking.md", "reaches {} / {} / {} (", PAPER_PRESET_1),
    Quote("README.md", "against the paper's {} / {} / {} —", PAPERS),
    Quote(
        "docs/results/model_checking.md",
        "best preset adds over it ({} / {} / {} points)",
        table1_gap(PAPER_PRESET),
    ),
    Quote(
        "docs/results/model_checking.md",
        "is not reached ({} / {} / {} points short on data seed 0",
        table1_gap(BEST, of=[95, 93, 90]),
    ),
    Quote("docs/how-it-works.md", "above the paper's {} / {} / {} —", PAPERS),
    Quote(
        "docs/how-it-works.md",
        "a distance rule ({} on Low, {} on High), while the learned GNN part alone is at "
        "chance ({} and {};",
        evidence_parts,
    ),
    Quote(
        "README.md",
        "the T-LEAF loss {} % (LSTM) / {} % (TCN) action accuracy; the exact loss {} % / {} %",
        fig4b(("lstm", "tleaf"), ("tcn", "tleaf"), ("lstm", "exact"), ("tcn", "exact")),
    ),
    Quote(
        "docs/how-it-works.md",
        "action accuracy by {} % (LSTM) and {} % (TCN)",
        fig4b(("lstm", "tleaf"), ("tcn", "tleaf")),
    ),
    Quote(
        "docs/how-it-works.md",
        "{} % (LSTM) and {} % (TCN) action accuracy, 5 of 5 seeds each",
        fig4b(("lstm", "exact"), ("tcn", "exact")),
    ),
    Quote(
        "docs/results/action_recognition.md",
        "the exact loss −log P(rules hold) gains {} % / {} % at every seed",
        fig4b(("lstm", "exact"), ("tcn", "exact")),
    ),
    Quote("README.md", "rule violations from {}–{} % to 0 %", violations_range),
    Quote("docs/how-it-works.md", "violations go from {}–{} % to 0 %", violations_range),
    Quote("docs/results/action_recognition.md", "from {}–{} % to 0 %", violations_range),
    Quote("docs/results/action_recognition.md", "by {} to {} % for every row", decoding_gain_range),
    Quote(
        "docs/how-it-works.md",
        "rises by about {} % (LSTM) and {} % (TCN)",
        decoding_gain("lstm", "tcn"),
    ),
    Quote("README.md", "the rules are worth at most {} the data", most_data_worth),
    Quote("docs/results/learning_curve.md", "The most anywhere is {},", most_data_worth),
    Quote("README.md", "gains most at 20 videos ({} %)", curve("20", "exact, argmax")),
    Quote(
        "docs/results/learning_curve.md",
        "{} % at 20 (argmax",
        lambda: [curve_rows().row("20", "exact, argmax")["Δ action (%)"]],
    ),
    Quote(
        "docs/results/learning_curve.md",
        "helps most where data is scarcest ({} % at 10, {} % at 20 videos)",
        lambda: curve("10", "exact, argmax", 1)() + curve("20", "exact, argmax", 1)(),
    ),
    Quote(
        "docs/results/learning_curve.md",
        "own gain ({} % at 20 videos)",
        curve("20", "exact, argmax"),
    ),
    Quote("README.md", "lowered accuracy instead ({} % at 20 videos", other_configuration),
    Quote("README.md", "still gained ({} %)", lambda: other_configuration()[1:]),
    Quote("README.md", "(ratio {})", cooking_ratio),
    Quote("docs/cooking.md", "median steps {}, 95 %", cooking_ratio),
    Quote(
        "docs/how-it-works.md",
        "the held-out ingredient sets ({} against {})",
        lambda: cooking_held_out_end("shield", "none"),
    ),
]


@pytest.mark.parametrize("quote", QUOTES, ids=lambda q: f"{q.page}: {q.template[:40]}")
def test_each_quoted_figure_matches_its_source(quote: Quote) -> None:
    expected = quote.template.format(*quote.values())
    text = _normal((ROOT / quote.page).read_text(encoding="utf-8"))
    assert _normal(expected) in text, f"{quote.page} should say: {expected}"


def test_the_curve_table_and_the_variant_table_agree() -> None:
    """The learning curve's accuracy table repeats the per-variant table's means."""
    summary = table("learning_curve.md", "videos", "none, argmax", "exact, argmax")
    variants = curve_rows()
    checked = 0
    for row in summary.rows:
        for column, cell in zip(summary.header[1:], row[1:], strict=True):
            if cell != "–":
                assert variants.row(row[0], column)["action acc (%)"] == cell, (row[0], column)
                checked += 1
    assert checked >= 40


def test_a_drifted_copy_fails(tmp_path: Path, monkeypatch) -> None:
    """The check itself: a copy that disagrees with its source is not found."""
    page = tmp_path / "page.md"
    page.write_text("the default q scores 90.28 /\n89.79 / 83.20 (Low / Moderate / High)\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    with pytest.raises(AssertionError, match="should say"):
        test_each_quoted_figure_matches_its_source(Quote("page.md", QUOTES[2].template, BEST))
    page.write_text(f"the default q scores {' / '.join(BEST())} (Low / Moderate / High)\n")
    test_each_quoted_figure_matches_its_source(Quote("page.md", QUOTES[2].template, BEST))
