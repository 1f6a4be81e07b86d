"""`Kept`: a bounded store of results computed from an automaton's structure.

Trainers that build rule sets from a model's predictions meet the same automata over other
atoms again and again; what depends on the automaton alone (`DFA.structure`: a conjunction's
table, a graph layout, monitor shares, the exact loss's arcs) is computed once and kept under
that key, the oldest dropped first once `limit` entries are held.
"""

from __future__ import annotations

from typing import Any


class Kept(dict):
    """A dict holding at most `limit` entries; `keep` adds one, dropping the oldest first."""

    def __init__(self, limit: int) -> None:
        super().__init__()
        self.limit = limit

    def keep(self, key: Any, value: Any) -> Any:
        """Store `value` under `key` (the oldest entry dropped at the limit); returns it."""
        if key not in self and len(self) >= self.limit:
            self.pop(next(iter(self)))
        self[key] = value
        return value
