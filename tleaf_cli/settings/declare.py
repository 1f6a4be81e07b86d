"""Settings of `tleaf mine-declare` (`DeclareSettings`): which Declare templates are mined from an
event log's training cases and how much evidence a rule needs. Pure Python: the command line
builds the command's options from this module.

The templates' meaning (name, arity, activation, LTLf formula) is `knowledge/templates.py`'s,
their mining `knowledge/declare.py`'s; this module (floor 0, which imports no knowledge module)
names them only, by the keys of `templates.TEMPLATES` (a test keeps the names equal).
"""

from __future__ import annotations

from dataclasses import dataclass

from tleaf_cli.errors import SettingError
from tleaf_cli.settings import check_values, setting

# Every Declare template, by its key in knowledge/templates.py's TEMPLATES (same order).
DECLARE_TEMPLATES = (
    "existence",
    "absence",
    "exactly",
    "init",
    "end",
    "choice",
    "exclusive_choice",
    "responded_existence",
    "co_existence",
    "response",
    "precedence",
    "succession",
    "alternate_response",
    "alternate_precedence",
    "alternate_succession",
    "chain_response",
    "chain_precedence",
    "chain_succession",
    "not_responded_existence",
    "not_co_existence",
    "not_response",
    "not_precedence",
    "not_succession",
    "not_chain_response",
    "not_chain_precedence",
    "not_chain_succession",
)
# Mined when no template is named: the ten tleaf mined before it knew the others (the figures of
# docs/knowledge.md and docs/results/event_logs.md are theirs).
DEFAULT_TEMPLATES = (
    "existence",
    "absence",
    "exactly",
    "init",
    "end",
    "response",
    "precedence",
    "succession",
    "chain_response",
    "not_co_existence",
)
# Repeat another template's formula on two activities (Not Responded Existence is Not
# Co-Existence; Not Response and Not Precedence are Not Succession; Not Chain Response and Not
# Chain Precedence are Not Chain Succession): mined when named, left out of "all".
SAME_AS_ANOTHER = (
    "not_responded_existence",
    "not_response",
    "not_precedence",
    "not_chain_response",
    "not_chain_precedence",
)
# "all": every other template (pm4py's 18 discovery templates, End, Choice, Exclusive Choice)
ALL_TEMPLATES = tuple(t for t in DECLARE_TEMPLATES if t not in SAME_AS_ANOTHER)
# the names these two templates had before (and keep as rule names: exactly_once.a)
TEMPLATE_ALIASES = {"exactly_once": "exactly", "not_coexistence": "not_co_existence"}


def template_keys(names: tuple[str, ...]) -> tuple[str, ...]:
    """`names` as keys of DECLARE_TEMPLATES (the aliases replaced), each once; SettingError
    naming the unknown or repeated one."""
    known = set(DECLARE_TEMPLATES) | set(TEMPLATE_ALIASES)
    unknown = [x for x in names if x not in known]
    if not names or unknown:
        raise SettingError(
            "templates",
            f"takes 'all' or names among {', '.join(DECLARE_TEMPLATES)} (or "
            f"{', '.join(TEMPLATE_ALIASES)}) separated by commas, not {', '.join(unknown) or '()'}",
        )
    keys = tuple(TEMPLATE_ALIASES.get(x, x) for x in names)
    twice = next((names[i] for i, t in enumerate(keys) if t in keys[:i]), None)
    if twice is not None:
        raise SettingError("templates", f"names '{twice}' twice; name each template once")
    return keys


def templates(text: str) -> tuple[str, ...]:
    """Template names as written on the command line ("init,end,response", or "all"), as keys,
    each once."""
    names = tuple(x.strip() for x in text.split(",") if x.strip())
    if names == ("all",):
        return ALL_TEMPLATES
    return template_keys(names)


@dataclass(frozen=True)
class DeclareSettings:
    """Every setting of a Declare mining run (written in the knowledge base's header)."""

    min_support: float = setting(
        0.9, "Share of the train cases a rule must hold on (vacuously too).", min=0.0
    )
    min_confidence: float = setting(
        0.9,
        "Share of the train cases that activate a relational rule (contain its activating "
        "activity: a of response.a.b, b of precedence.a.b, either of succession.a.b) that must "
        "satisfy it.",
        min=0.0,
    )
    min_activated: int = setting(
        10, "Train cases that must activate a relational rule (fewer: trivially satisfied).", min=1
    )
    min_joint_support: float = setting(
        0.0,
        "Share of the train cases the whole knowledge base must hold on: the rules that pass "
        "the thresholds are taken by falling support while their conjunction still holds on "
        "this share (a rule that would break it is left out); 0: every rule that passes.",
        min=0.0,
    )
    templates: tuple[str, ...] | None = setting(
        None,
        "The templates to mine, separated by commas, by their keys in knowledge/templates.py "
        "(chain_precedence, not_succession, ...); all: the 21 that do not repeat another's "
        "formula.",
        auto="existence, absence, exactly, init, end, response, precedence, succession, "
        "chain_response, not_co_existence",
        parse=templates,
    )

    @property
    def chosen_templates(self) -> tuple[str, ...]:
        """The templates to mine, as keys (DEFAULT_TEMPLATES when none were named)."""
        return DEFAULT_TEMPLATES if self.templates is None else template_keys(self.templates)

    def check(self) -> None:
        """SettingError for a share above 1 (the command line checks the lower bounds), or
        templates that are not a tuple of distinct known names."""
        check_values(self)
        chosen = self.templates
        if chosen is not None:
            if not (isinstance(chosen, tuple) and all(isinstance(t, str) for t in chosen)):
                raise SettingError(
                    "templates",
                    f"is a tuple of names among {', '.join(DECLARE_TEMPLATES)}, not "
                    + (f"the string {chosen!r}" if isinstance(chosen, str) else repr(chosen)),
                )
            template_keys(chosen)
        for name in ("min_support", "min_confidence", "min_joint_support"):
            if getattr(self, name) > 1:
                raise SettingError(
                    name, f"is a share of cases: at most 1, not {getattr(self, name)}"
                )
