"""The one in-memory shape of a dataset of sequences: `Case` (one sequence) and `Cases` (all of
them, as read).

Every reader of sequences gives `Cases`: an event log (data/log_readers.py, a case of
activities), CaptainCook4D's recordings (data/captaincook.py, a recording of steps: `Recording`,
a `Case` with the recording's own fields), and a `cases` artifact read back
(data/event_logs.py `read_cases`). A case is its id, its activities in time order, each
activity's formula atom, their UTC times, and its split; `Cases` holds the cases in the source's
order with the activity -> atom map, the source's path, its parameters (provenance) and what was
skipped reading it (`SkipReport`).

A case may keep event attributes (`read-log --attributes org:resource`: one value per event,
None where the event has none) and case attributes (one value per case). An event's *letter* is
the set of atoms true at it: its activity's atom and, for each kept attribute with a value, the
atom of "attribute is value" (`activity_names.attribute_atom`), so a rule can speak of "Closed
done by Value 3" as `closed & org_resource__value_3` (`Case.letters`). A rule's MP-Declare
condition is an atom of its own, true at an event where its test holds on the event's values
(`EventTest`, knowledge/decl_conditions.py): `Case.letters(tests=...)` adds those.
"""

from __future__ import annotations

import functools
import os
from collections import Counter
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any, Generic, Protocol, TypeVar

from tleaf_cli.data.activity_names import attribute_atom
from tleaf_cli.data.skip_report import SkipReport
from tleaf_cli.errors import ArgumentTypeError

_attribute_atom = functools.lru_cache(maxsize=1 << 16)(attribute_atom)  # a log repeats its values


class EventTest(Protocol):
    """A test on one event's attribute values, true or false at each event (an MP-Declare
    condition: knowledge/decl_conditions.py `EventCondition`)."""

    @property
    def attributes(self) -> tuple[str, ...]:
        """The event attributes it reads."""
        ...

    def holds(self, values: Mapping[str, str | None]) -> bool:
        """Whether it holds at an event with these values (attribute -> value or None)."""
        ...


@dataclass(frozen=True)
class Case:
    """One case: its activities in time order, their UTC timestamps, atoms and split; the event
    attributes kept (attribute -> one value per event, None where an event has none) and the
    case attributes kept (attribute -> value or None)."""

    case_id: str
    activities: tuple[str, ...]
    atoms: tuple[str, ...]
    timestamps: tuple[datetime, ...]
    split: str
    attributes: dict[str, tuple[str | None, ...]] = field(
        default_factory=dict, kw_only=True, hash=False
    )
    case_attributes: dict[str, str | None] = field(default_factory=dict, kw_only=True, hash=False)

    def __len__(self) -> int:
        return len(self.activities)

    def letters(
        self, attributes: Sequence[str] | None = None, tests: Mapping[str, EventTest] | None = None
    ) -> tuple[frozenset[str], ...]:
        """Each event's atoms, true together: its activity's atom; for each kept event attribute
        (or only those named in `attributes`) with a value, `attribute_atom(attribute, value)`;
        and each atom of `tests` whose test holds on the event's values (an attribute the case
        does not keep reads as no value). KeyError for a named attribute the case does not keep."""
        names = list(self.attributes) if attributes is None else list(attributes)
        columns = [(name, self.attributes[name]) for name in names]
        out = []
        for i, atom in enumerate(self.atoms):
            letter = [atom] + [
                _attribute_atom(name, values[i])
                for name, values in columns
                if values[i] is not None
            ]
            if tests:
                event = {name: column[i] for name, column in self.attributes.items()}
                letter += [a for a, test in tests.items() if test.holds(event)]
            out.append(frozenset(letter))
        return tuple(out)


C = TypeVar("C", bound=Case)


@dataclass
class Cases(Generic[C]):
    """Cases as read: in the source's order, the activity -> atom map, the source (`path`), its
    parameters, what was skipped, and the files read (`inputs`, for the provenance). `Cases[C]`:
    cases of the kind C (`Case`, or a dataset's own, e.g. `Recording`)."""

    cases: list[C]
    activity_atoms: dict[str, str]
    path: str
    params: dict[str, Any] = field(default_factory=dict)
    skips: SkipReport = field(default_factory=SkipReport)
    inputs: list[Path] = field(default_factory=list)
    attribute_names: tuple[str, ...] = ()  # the event attributes each case keeps, in order
    case_attribute_names: tuple[str, ...] = ()  # the case attributes each case keeps

    def __len__(self) -> int:
        return len(self.cases)

    def __iter__(self) -> Iterator[C]:
        return iter(self.cases)

    @property
    def events(self) -> int:
        """The activities of every case together."""
        return sum(len(c) for c in self.cases)

    def split_counts(self) -> dict[str, int]:
        """split -> cases, in name order."""
        return dict(sorted(Counter(c.split for c in self.cases).items()))


def source_path(path: object, what: str) -> str | os.PathLike:
    """`path` if it names a file (a str or a path), else ArgumentTypeError naming `what`."""
    if not isinstance(path, str | os.PathLike):
        raise ArgumentTypeError(
            "path", f"expected the path of {what}, not {type(path).__name__} {path!r}"
        )
    return path
