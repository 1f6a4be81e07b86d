"""Every relative link of README.md and docs/ leads somewhere: the file exists, and an anchor
(`[..](file.md#anchor)`, `[..](#anchor)`) names a heading of that file, slugged as GitHub slugs
headings. A renamed heading or a moved page fails here instead of on a reader's click."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).parent.parent
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").rglob("*.md")])
FENCE = re.compile(r"^\s*(`{3,}|~{3,})")
HEADING = re.compile(r"^ {0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
# [text](target) outside inline code; the target has no spaces (a title after one is dropped)
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
IMAGE = re.compile(r"!\[[^\]]*\]\(([^)\s]+)\)")


def _outside_fences(text: str) -> list[tuple[int, str]]:
    """(line number, line) of the lines outside fenced code blocks."""
    out, fence = [], None
    for number, line in enumerate(text.splitlines(), start=1):
        match = FENCE.match(line)
        if match:
            mark = match.group(1)
            if fence is None:
                fence = mark
            elif mark.startswith(fence[0]) and len(mark) >= len(fence):
                fence = None
            continue
        if fence is None:
            out.append((number, line))
    return out


def _prose_lines(text: str) -> list[tuple[int, str]]:
    """(line number, line) of the lines outside fenced code blocks, inline code removed."""
    return [(n, re.sub(r"`[^`]*`", "``", line)) for n, line in _outside_fences(text)]


def github_slug(heading: str) -> str:
    """GitHub's anchor for a heading's text: markup dropped, lower case, every character that is
    not a letter, digit, space, hyphen or underscore removed, spaces made hyphens."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link's text only
    text = re.sub(r"<[^>]+>", "", text)
    text = text.replace("`", "").replace("*", "")
    text = text.strip().lower()
    text = "".join(c for c in text if c.isalnum() or c in " -_")
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """Every heading anchor of a Markdown file, slugged from the heading as written (inline code
    kept); a repeated slug gets -1, -2, ... as on GitHub."""
    seen: dict[str, int] = {}
    out = set()
    for _, line in _outside_fences(path.read_text(encoding="utf-8")):
        heading = HEADING.match(line)
        if heading:
            slug = github_slug(heading.group(2))
            n = seen.get(slug, 0)
            out.add(slug if n == 0 else f"{slug}-{n}")
            seen[slug] = n + 1
    return out


def broken_links(page: Path) -> list[str]:
    """'line: target (why)' for each relative link of `page` that leads nowhere."""
    broken = []
    for number, line in _prose_lines(page.read_text(encoding="utf-8")):
        for target in LINK.findall(line) + IMAGE.findall(line):
            if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
                continue
            path_part, _, anchor = target.partition("#")
            linked = (page.parent / path_part).resolve() if path_part else page
            if not linked.exists():
                broken.append(f"{number}: {target} (no such file)")
            elif anchor and linked.suffix == ".md" and anchor not in anchors(linked):
                broken.append(f"{number}: {target} (no such heading in {linked.name})")
    return broken


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_link_leads_somewhere(page: Path) -> None:
    assert broken_links(page) == []


def test_the_slugs_are_githubs() -> None:
    assert github_slug("GAIL and the logic loss (`tleaf train-task cooking`)") == (
        "gail-and-the-logic-loss-tleaf-train-task-cooking"
    )
    assert github_slug("5. The embedder and the tleaf loss") == "5-the-embedder-and-the-tleaf-loss"
    assert github_slug("At 60 training videos (the paper's Fig. 4B)") == (
        "at-60-training-videos-the-papers-fig-4b"
    )
    assert github_slug("Formula → automaton, q_e") == "formula--automaton-q_e"


def test_a_broken_anchor_and_a_missing_file_are_found(tmp_path: Path) -> None:
    (tmp_path / "a.md").write_text("# Top\n\n## Top\n\n```\n# not a heading\n```\n")
    page = tmp_path / "b.md"
    page.write_text(
        "[ok](a.md#top-1) [ok](a.md) [bad](a.md#not-a-heading) [gone](c.md) [web](https://x.org)\n"
        "`[in code](c.md)`\n"
    )
    assert broken_links(page) == [
        "1: a.md#not-a-heading (no such heading in a.md)",
        "1: c.md (no such file)",
    ]
