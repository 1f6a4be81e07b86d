"""Which of a knowledge base's rules a q can read: the tleaf loss's rules, checked before training.

The tleaf loss embeds a rule set with q, and q reads only the atoms its edge embedder q_e was
trained on; a rule naming any other atom is left out of the loss. A q trained on other rules
(another knowledge base, a tier's a, b, c) can read none of them: the loss is then 0 at every
step and the run trains exactly as without it. `check_q_covers` refuses that case, and counts
what a q that knows only some of the atoms leaves out, so the trainer can say so. No torch here.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path

from tleaf_cli.errors import SettingError
from tleaf_cli.knowledge.base import KnowledgeBase

SHOWN_ATOMS = 5  # missing atoms named in a message before "and N more"


@dataclass(frozen=True)
class QCoverage:
    """How much of a knowledge base a q can read."""

    rules: int  # the knowledge base's rules
    left_out: int  # of them, those naming an atom q does not know (the loss leaves them out)
    missing_atoms: tuple[str, ...]  # the atoms the rules name that q does not know, sorted

    def missing_text(self) -> str:
        """The first few missing atoms, then how many more."""
        shown = ", ".join(self.missing_atoms[:SHOWN_ATOMS])
        more = len(self.missing_atoms) - SHOWN_ATOMS
        return shown + (f" and {more} more" if more > 0 else "")

    def left_out_text(self) -> str:
        """One line: how many rules the loss leaves out, and why."""
        return (
            f"the tleaf loss leaves out {self.left_out} of the knowledge base's {self.rules} "
            f"rules: they name atoms q was not trained on ({len(self.missing_atoms)} atoms: "
            f"{self.missing_text()})"
        )

    def as_dict(self) -> dict:
        return {
            "kb_rules": self.rules,
            "kb_rules_unknown_to_q": self.left_out,
            "atoms_unknown_to_q": len(self.missing_atoms),
        }


def q_coverage(kb: KnowledgeBase, known: Collection[str]) -> QCoverage:
    """The rules of `kb` whose atoms are not all in `known` (q's atoms), and those atoms."""
    known = set(known)
    unread = [r for r in kb if not known.issuperset(r.atoms)]
    missing = sorted({a for r in unread for a in r.atoms} - known)
    return QCoverage(len(kb), len(unread), tuple(missing))


def check_q_covers(kb: KnowledgeBase, known: Collection[str], embedder: str | Path) -> QCoverage:
    """`q_coverage`, and SettingError (setting `embedder`) when q can read none of the rules:
    a loss on no rule is 0 at every step and trains nothing."""
    coverage = q_coverage(kb, known)
    if coverage.rules and coverage.left_out == coverage.rules:
        raise SettingError(
            "embedder",
            f"q at {embedder} can read none of the knowledge base's {coverage.rules} rules: "
            f"each names atoms q was not trained on ({len(coverage.missing_atoms)} atoms: "
            f"{coverage.missing_text()}), so the tleaf loss would be 0 and train nothing; "
            "train q on this knowledge base's rules (kb-extract, compile-dfa, gen-traces, "
            "train-edge, train-meta: pipelines/activities_q.mk)",
        )
    return coverage
