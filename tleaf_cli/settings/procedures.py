"""Settings of `tleaf task-graph` (`TaskGraphSettings`): which rules a precedence graph gives
besides one per edge. Pure Python: the command line builds the command's options from this
module; the rules' meaning is in `knowledge/task_graphs.py`."""

from __future__ import annotations

from dataclasses import dataclass

from tleaf_cli.settings import check_values, setting


@dataclass(frozen=True)
class TaskGraphSettings:
    """Which rules besides the edges' a task graph gives (written in the knowledge base)."""

    at_most_once: bool = setting(
        False, "Also a rule per step: it occurs at most once, G(a -> WX G !a)."
    )
    last_step_ends: bool = setting(
        False,
        "Also a rule per recipe: the last step is one of END's predecessors (the graph's sinks "
        "when it has no END), F(last & (p1 | p2 ...)).",
    )

    def check(self) -> None:
        check_values(self)
