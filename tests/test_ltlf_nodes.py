"""ltlf2dfa's node classes are imported in one place (logic/ltlf_nodes.py), which every module
that walks formula trees reads them from."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import ltlf2dfa.ltlf

from tleaf_cli.logic import ltlf_nodes

PACKAGE = Path(__file__).parent.parent / "tleaf_cli"
WALKERS = ("logic.grammar", "logic.progression", "logic.semantics", "embed.graphs")


def test_the_node_classes_are_ltlf2dfas_own() -> None:
    assert len(ltlf_nodes.__all__) == 16
    for name in ltlf_nodes.__all__:
        assert getattr(ltlf_nodes, name) is getattr(ltlf2dfa.ltlf, name)
        assert issubclass(getattr(ltlf_nodes, name), ltlf2dfa.ltlf.LTLfFormula)


def test_every_walker_reads_them_from_the_one_module() -> None:
    for module in WALKERS:
        walker = importlib.import_module(f"tleaf_cli.{module}")
        assert walker.ltlf is ltlf_nodes, module


def test_no_other_module_lists_them_again() -> None:
    """A list of more than a few node classes imported from ltlf2dfa is written only once."""
    listing = re.compile(r"from ltlf2dfa\.ltlf import \([^\n]*\n((?:\s+LTLf\w+,\n)+)\)")
    long = [
        p.relative_to(PACKAGE).as_posix()
        for p in sorted(PACKAGE.rglob("*.py"))
        for m in listing.finditer(p.read_text(encoding="utf-8"))
        if m.group(1).count(",") > 12
    ]
    assert long == ["logic/ltlf_nodes.py"]
