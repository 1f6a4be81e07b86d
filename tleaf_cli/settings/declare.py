"""Settings of `tleaf mine-declare` (`DeclareSettings`): which Declare templates are mined from an
event log's training cases and how much evidence a rule needs. Pure Python: the command line
builds the command's options from this module; the templates' meaning is in
`knowledge/declare.py`."""

from __future__ import annotations

from dataclasses import dataclass

from tleaf_cli.errors import SettingError
from tleaf_cli.settings import check_values, setting

# The Declare templates knowledge/declare.py knows (kept equal to its TEMPLATES by a test).
DECLARE_TEMPLATES = (
    "existence",
    "absence",
    "exactly_once",
    "init",
    "end",
    "response",
    "precedence",
    "succession",
    "chain_response",
    "not_coexistence",
)


def templates(text: str) -> tuple[str, ...]:
    """Template names as written on the command line ("init,end,response"), each once."""
    names = tuple(x.strip() for x in text.split(",") if x.strip())
    unknown = [x for x in names if x not in DECLARE_TEMPLATES]
    if not names or unknown:
        raise SettingError(
            "templates",
            f"takes names among {', '.join(DECLARE_TEMPLATES)} separated by commas, not '{text}'",
        )
    _check_once(names)
    return names


def _check_once(names: tuple[str, ...]) -> None:
    """SettingError for a template named twice: it would be mined, and written, twice."""
    twice = next((t for i, t in enumerate(names) if t in names[:i]), None)
    if twice is not None:
        raise SettingError("templates", f"names '{twice}' twice; name each template once")


@dataclass(frozen=True)
class DeclareSettings:
    """Every setting of a Declare mining run (written in the knowledge base's header)."""

    min_support: float = setting(
        0.9, "Share of the train cases a rule must hold on (vacuously too).", min=0.0
    )
    min_confidence: float = setting(
        0.9,
        "Share of the train cases that activate a relational rule (its first activity occurs; "
        "for precedence its second) that must satisfy it.",
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
        "The templates to mine, separated by commas: existence, absence, exactly_once, init, end, "
        "response, precedence, succession, chain_response, not_coexistence.",
        auto="all",
        parse=templates,
    )

    @property
    def chosen_templates(self) -> tuple[str, ...]:
        """The templates to mine (all when none were named)."""
        return self.templates or DECLARE_TEMPLATES

    def check(self) -> None:
        """SettingError for a share above 1 (the command line checks the lower bounds), or
        templates that are not a tuple of distinct known names."""
        check_values(self)
        chosen = self.templates
        if chosen is not None:
            if not (
                isinstance(chosen, tuple) and chosen and all(t in DECLARE_TEMPLATES for t in chosen)
            ):
                raise SettingError(
                    "templates",
                    f"is a tuple of names among {', '.join(DECLARE_TEMPLATES)}, not "
                    + (f"the string {chosen!r}" if isinstance(chosen, str) else repr(chosen)),
                )
            _check_once(chosen)
        for name in ("min_support", "min_confidence", "min_joint_support"):
            if getattr(self, name) > 1:
                raise SettingError(
                    name, f"is a share of cases: at most 1, not {getattr(self, name)}"
                )
