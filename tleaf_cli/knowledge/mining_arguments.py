"""The miners' argument checks: what `mine_declare`, `measure_declare`, `holding_shares` and
`mine_knowledge_base` are given, checked once per call before any work.

A wrong value would otherwise be used silently: a string of cases is mined letter by letter, a
template named twice is written twice (a knowledge base no later stage reads), a NaN threshold
compares false with every count and drops every rule. Each check raises `ArgumentTypeError` or
`ArgumentError` (tleaf_cli/errors.py) naming the argument as the signature spells it, what was
given and what to pass; the command line checks its settings before it calls these functions.
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from tleaf_cli.arguments import given, sequence
from tleaf_cli.errors import ArgumentError, ArgumentTypeError


def cases(value: Any, argument: str = "cases") -> list[Sequence[str]]:
    """A sequence of cases, each a sequence of activities (str); a str at either level is
    refused (it would be read letter by letter). Empty cases are left to the caller."""
    out = sequence(value, argument, "cases (each a sequence of activities, str)")
    for i, case in enumerate(out):
        if type(case) not in (tuple, list):
            sequence(case, f"{argument}[{i}]", "activities (str)")
        if not all(type(x) is str for x in case):
            t = next(t for t, x in enumerate(case) if not isinstance(x, str))
            raise ArgumentTypeError(
                f"{argument}[{i}][{t}]", f"must be an activity (a str), not {given(case[t])}"
            )
    return out


def names(value: Any, argument: str, what: str) -> tuple[str, ...]:
    """A collection of names (str), not itself a str; `what` says of what (in the message)."""
    if isinstance(value, str | bytes) or not isinstance(value, Iterable):
        raise ArgumentTypeError(argument, f"must be a collection of {what}, not {given(value)}")
    out = tuple(value)
    for i, x in enumerate(out):
        if not isinstance(x, str):
            raise ArgumentTypeError(argument, f"item {i} must be a str, not {given(x)}")
    return out


def templates(
    value: Any, known: Sequence[str], aliases: Mapping[str, str] | None = None
) -> tuple[str, ...]:
    """Declare template names among `known` (or `aliases`' keys, replaced by their values), each
    once (a template named twice would be mined, and written, twice)."""
    aliases = aliases or {}
    chosen = names(value, "templates", "Declare template names, e.g. ('init', 'end')")
    for t in chosen:
        if t not in known and t not in aliases:
            raise ArgumentError(
                "templates", f"unknown Declare template '{t}' (known: {', '.join(known)})"
            )
    keys = tuple(aliases.get(t, t) for t in chosen)
    twice = next((chosen[i] for i, t in enumerate(keys) if t in keys[:i]), None)
    if twice is not None:
        raise ArgumentError("templates", f"names '{twice}' twice; name each template once")
    if not chosen:
        raise ArgumentError("templates", f"is empty; name one or more of {', '.join(known)}")
    return keys


def share(value: Any, argument: str) -> float:
    """A share of cases: a real number from 0 to 1 (NaN refused: it compares false with all)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ArgumentTypeError(argument, f"must be a number from 0 to 1, not {_shown(value)}")
    if not 0 <= value <= 1:
        raise ArgumentError(argument, f"is a share of cases, 0 to 1, not {value}")
    return float(value)


def count(value: Any, argument: str, least: int) -> int:
    """A number of cases or sequences: an int (not a bool, not a float such as NaN) ≥ `least`."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ArgumentTypeError(
            argument, f"must be an int (a number of cases), not {_shown(value)}"
        )
    if value < least:
        raise ArgumentError(argument, f"must be at least {least}, not {value}")
    return int(value)


def _shown(value: Any) -> str:
    """A number as written (`nan`, `2.5`), anything else as `arguments.given` describes it."""
    return repr(value) if isinstance(value, numbers.Number) else given(value)
