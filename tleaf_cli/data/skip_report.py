"""What a dataset reader skipped or repaired, counted by kind with the first few places named.

Both readers (data/log_readers.py, data/captaincook.py) fill one `SkipReport`, so a log and a
set of recordings say what they left out in the same words: the summary line's phrase
(`text`), and the provenance's `skipped` (kind -> count) and `skipped_examples` (kind -> the
first `EXAMPLES` places, e.g. 'case 17, line 230'). A repair (events sorted into time order, a
case id renamed) is not a skip: the reader words it itself (`repairs`), and it leads the phrase.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

EXAMPLES = 5  # places kept per kind of skip, for the report


@dataclass
class SkipReport:
    """Skips by kind (count, and the first few places), and phrases for what was repaired."""

    skipped: dict[str, int] = field(default_factory=dict)
    examples: dict[str, list[str]] = field(default_factory=dict)
    repairs: list[str] = field(default_factory=list)

    def skip(self, kind: str, where: str | None = None, count: int = 1) -> None:
        """Count `count` skips of `kind`; name the place `where` among the first few."""
        self.skipped[kind] = self.skipped.get(kind, 0) + count
        if where is not None:
            places = self.examples.setdefault(kind, [])
            if len(places) < EXAMPLES:
                places.append(where)

    def text(self) -> str:
        """Everything in one phrase: 'cases sorted by time: 2, events without timestamp: 3
        (case 7, line 12; ...)', or 'none'."""
        parts = list(self.repairs)
        for kind, count in self.skipped.items():
            places = self.examples.get(kind, [])
            more = "; ..." if count > len(places) else ""
            parts.append(f"{kind}: {count}" + (f" ({'; '.join(places)}{more})" if places else ""))
        return ", ".join(parts) or "none"

    def params(self) -> dict[str, Any]:
        """The provenance's keys: `skipped` and `skipped_examples`."""
        return {"skipped": dict(self.skipped), "skipped_examples": dict(self.examples)}

    @classmethod
    def from_params(cls, params: dict[str, Any]) -> SkipReport:
        """The skips an artifact's provenance holds (`params`), as written by `params`."""
        return cls(dict(params.get("skipped") or {}), dict(params.get("skipped_examples") or {}))
