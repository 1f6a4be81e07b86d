"""Settings of `tleaf task-graph` (`TaskGraphSettings`): which rules a precedence graph gives
besides one per edge; and of `tleaf recording-activities` (`StepFeatureSettings`, with
TaskGraphSettings' rules): how each step's drawn feature is made. Pure Python: the command line
builds the commands' options from this module; the rules' meaning is in
`knowledge/task_graphs.py`, the features' in `tasks/step_recognition/activities.py`."""

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


@dataclass(frozen=True)
class StepFeatureSettings:
    """How `recording-activities` draws each step's feature along a real recording."""

    feature_dim: int = setting(32, "Feature dimension D.", min=1)
    noise: float = setting(2.0, "Noise σ of one frame around its step's mean.", min=0.0)
    frame_seconds: float = setting(
        10.0,
        "Seconds one frame stands for: a step of d s averages max(1, round(d / this)) frames.",
        min=0.001,
    )
    seed: int = setting(0, "Seed of the class means and the noise.")

    def check(self) -> None:
        check_values(self)
