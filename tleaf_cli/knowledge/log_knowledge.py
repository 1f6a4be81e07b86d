"""Knowledge for an event log, as files: Declare rules mined from a cases artifact's train split
(`mine_log`, for `tleaf mine-declare`) and the peers' formulas.tsv as a `.ltl`
(`convert_peer_file`, for `tleaf peer-formulas`).

`mine_log` writes the knowledge base — `knowledge/declare.py`'s `.ltl`, with a header saying where
it comes from, the settings, and which activity each atom names; or, for an `out` ending in
`.decl`, a Declare model in RuM's format (`decl_writer`), the activities by their names in the
log — and, beside it, a TSV with every rule's measures on the train split and its support on the
test split: the share of test cases the rule holds on, i.e. how well the mined knowledge carries
over to unseen cases.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from tleaf_cli.data.artifacts import read_text_file, write_text_atomic
from tleaf_cli.data.event_logs import iter_sequences, read_cases
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.decl_writer import decl_text
from tleaf_cli.knowledge.declare import (
    Measured,
    declare_text,
    holding_shares,
    measure_declare,
    mine_declare,
    passing,
)
from tleaf_cli.knowledge.peer_formulas import PeerFormula, peer_ltl_text, read_peer_formulas
from tleaf_cli.settings.declare import DeclareSettings


def support_table_path(kb: str | os.PathLike) -> Path:
    """Where `mine_log` writes the rules' measures: beside the knowledge base, `.tsv`."""
    return Path(kb).with_suffix(".tsv")


@dataclass(frozen=True)
class MinedLog:
    """What `mine_log` found: the rules with their train measures and test support."""

    rules: list[Measured]
    test_support: list[float]  # per rule; nan without test cases
    test_joint: float  # share of the test cases all the rules hold on; nan without test cases
    train_cases: int
    test_cases: int
    activities: int  # distinct activities in the train split
    why_none: str = ""  # with no rule mined: which thresholds stopped the candidates

    def summary(self) -> str:
        """One line on what was mined and how it carries to the test split; with no rule, why
        (the thresholds each stage of candidates failed) and how many test cases there are."""
        mined = f"{self.train_cases} train cases, {self.activities} activities"
        test = f"{self.test_cases} test cases" if self.test_cases else "no test cases"
        if not self.rules:
            return f"no rule mined from {mined}: {self.why_none}; {test}"
        shares = self.test_support
        if not self.test_cases:
            return f"{len(self.rules)} rules from {mined}; {test}"
        return (
            f"{len(self.rules)} rules from {mined}; on the {test} each holds on "
            f"{min(shares):.1%} to {max(shares):.1%} (mean {sum(shares) / len(shares):.1%}), "
            f"all of them on {self.test_joint:.1%}"
        )


def mine_log(
    cases_path: str | os.PathLike, out: str | os.PathLike, settings: DeclareSettings
) -> MinedLog:
    """Mine Declare rules from the train split of the cases artifact `cases_path`, write them to
    `out` (a `.decl` when its name ends so, else a `.ltl`) and their measures to
    `support_table_path(out)`. InputError, nothing written, for an activity a `.decl` cannot
    name."""
    settings.check()
    cases = read_cases(cases_path)
    train = list(iter_sequences(cases, "train"))
    test = list(iter_sequences(cases, "test"))
    if not train:
        raise InputError(f"{cases_path}: no train cases to mine rules from")
    mined = mine_declare(
        train,
        min_support=settings.min_support,
        min_confidence=settings.min_confidence,
        min_activated=settings.min_activated,
        min_joint_support=settings.min_joint_support,
        templates=settings.chosen_templates,
    )
    shares, joint = holding_shares([m.constraint for m in mined], test)
    named = {a for m in mined for a in m.constraint.activities}
    activity_of = {atom: name for name, atom in cases.activity_atoms.items()}
    header = [
        f"Declare constraints mined by tleaf mine-declare from {Path(cases_path).name}: "
        f"{len(mined)} rules from its {len(train)} train cases",
        "settings: "
        + ", ".join(f"{k} {_shown(v)}" for k, v in vars(settings).items() if k != "templates")
        + f", templates {_shown(settings.chosen_templates)}",
        "each rule: support (share of train cases it holds on); relational rules also confidence "
        "(share of the cases that activate it) and activated cases",
        *(f"atom {a} = activity {activity_of.get(a, a)!r}" for a in sorted(named)),
        "",
    ]
    if Path(out).suffix.lower() == ".decl":
        text = decl_text(mined, activity_of, cases.activity_atoms)
    else:
        text = declare_text(mined, header)
    rows = ["rule\tformula\ttrain_support\ttrain_confidence\ttrain_activated\ttest_support"]
    for m, share in zip(mined, shares, strict=True):
        rows.append(
            f"{m.constraint.name}\t{m.constraint.formula}\t{m.support:.4f}\t{m.confidence:.4f}\t"
            f"{m.activated}\t{share:.4f}"
        )
    write_text_atomic(out, text)
    write_text_atomic(support_table_path(out), "\n".join(rows) + "\n")
    activities = len({a for case in train for a in case})
    why = "" if mined else _why_none(train, settings)
    return MinedLog(mined, shares, joint, len(train), len(test), activities, why)


def _why_none(train: list[tuple[str, ...]], settings: DeclareSettings) -> str:
    """Why `settings` mined no rule from `train`: how many candidates passed each threshold."""
    measured = measure_declare(train, settings.chosen_templates)
    supported, confident, activated = passing(
        measured, settings.min_support, settings.min_confidence, settings.min_activated
    )
    said = (
        f"of {len(measured)} candidate rules, {len(supported)} hold on at least "
        f"{settings.min_support:g} of the train cases, {len(confident)} of those with "
        f"confidence at least {settings.min_confidence:g}, {len(activated)} of those (if "
        f"relational) with at least {settings.min_activated} activating cases"
    )
    if activated:  # every one left out for the joint support
        said += f", and none keeps the rules' joint support at {settings.min_joint_support:g}"
    return said


def _shown(value: object) -> str:
    return ",".join(map(str, value)) if isinstance(value, tuple) else str(value)


def convert_peer_file(
    tsv: str | os.PathLike,
    out: str | os.PathLike,
    cases_path: str | os.PathLike | None = None,
    log: str | None = None,
) -> list[PeerFormula]:
    """Their formulas.tsv as a `.ltl` at `out`, one rule per (log, kind) (only `log`'s rows when
    given); activities become atoms by the map of the cases artifact `cases_path` when given (the
    log's own), else by `activity_atoms` of each formula's activities. InputError naming the line
    for a bad row."""
    path = Path(tsv)
    text = read_text_file(path)
    atoms = read_cases(cases_path).activity_atoms if cases_path is not None else None
    try:
        formulas = read_peer_formulas(text, atoms, log)
    except InputError as e:
        raise InputError(f"{path}: {e}") from None
    if not formulas:
        which = f" for log '{log}'" if log is not None else ""
        raise InputError(f"{path}: no formulas{which} (a header, then log, kind, formula rows)")
    header = [
        f"Di Francescomarino et al.'s a-priori formulas, from {path.name}, in tleaf's syntax",
        "each rule: their formula as written, then <log>.<strong|weak>: the formula (LTLf on "
        "the completed case)",
        "",
    ]
    write_text_atomic(out, peer_ltl_text(formulas, header))
    return formulas
