"""Every results page reads table first: under 400 lines, its first table within its first 15
lines (the table, then the command and its cost, then the rest). Method detail belongs on the
method pages (docs/activities.md, docs/losses.md, ...), not in front of the result."""

from __future__ import annotations

from itertools import pairwise
from pathlib import Path

import pytest

RESULTS = Path(__file__).parent.parent / "docs" / "results"
PAGES = sorted(RESULTS.glob("*.md"))
MOST_LINES = 400
TABLE_BY = 15


def first_table_line(text: str) -> int | None:
    """The 1-based line of the first Markdown table's header, or None."""
    lines = text.splitlines()
    for number, (line, below) in enumerate(pairwise(lines), start=1):
        if line.startswith("|") and below.startswith("|---"):
            return number
    return None


def test_there_are_results_pages() -> None:
    assert {"model_checking.md", "action_recognition.md", "cooking.md"} <= {p.name for p in PAGES}


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_a_results_page_is_short_and_opens_with_its_table(page: Path) -> None:
    text = page.read_text(encoding="utf-8")
    assert len(text.splitlines()) < MOST_LINES, f"{page.name}: split it or move method detail"
    line = first_table_line(text)
    assert line is not None and line <= TABLE_BY, f"{page.name}: first table at line {line}"


def test_first_table_line() -> None:
    assert first_table_line("# t\n\ntext | not a table\n\n| a |\n|---|\n| 1 |\n") == 5
    assert first_table_line("# t\n\n| a |\n") is None
