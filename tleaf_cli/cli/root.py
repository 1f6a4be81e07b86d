"""The `tleaf` command itself: its Typer app, the `eval` and `train-task` groups, every command
registered under its name (in the order --help lists them), and the entry point `main`.

Each command lives in the module of its stage family (compile, generate, knowledge, event_logs,
procedures, embedder, model_checking, action_recognition, next_activity, cooking; runs.py holds
what the sequence tasks' train-task commands print); those modules read arguments, call the
library and map its errors to exit codes. The library is imported inside each command, so
`tleaf --help` and light commands start fast (ltlf2dfa alone pulls in sympy).
"""

from __future__ import annotations

import gc
from typing import Annotated

import typer

from tleaf_cli import __version__, ui
from tleaf_cli.cli.action_recognition import (
    eval_action_recognition,
    eval_choose_lambda,
    eval_learning_curve,
    eval_violations,
    train_task_action_recognition,
)
from tleaf_cli.cli.compile import compile_dfa, inspect
from tleaf_cli.cli.conformance import check_cases
from tleaf_cli.cli.cooking import eval_cooking, train_task_cooking
from tleaf_cli.cli.embedder import embed, train_edge, train_meta
from tleaf_cli.cli.event_logs import mine_declare, peer_formulas, read_log, split_cases
from tleaf_cli.cli.formatting import Command, Group
from tleaf_cli.cli.generate import gen_activities, gen_demos, gen_formulas, gen_traces
from tleaf_cli.cli.knowledge import cooking_kb, demos_kb, kb_extract
from tleaf_cli.cli.model_checking import eval_model_checking, eval_table, eval_tsne
from tleaf_cli.cli.next_activity import eval_next_activity, train_task_next_activity
from tleaf_cli.cli.predict import predict
from tleaf_cli.cli.procedures import (
    check_recordings,
    read_recordings,
    recipe_formulas,
    recording_traces,
    task_graph,
)
from tleaf_cli.cli.step_recognition import eval_step_recognition, recording_activities

app = typer.Typer(
    name="tleaf",
    cls=Group,
    help="T-LEAF toolchain: LTLf rules -> DFAs -> embeddings -> logic losses.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)
eval_app = typer.Typer(
    cls=Group, help="Evaluate embedders and trained models.", no_args_is_help=True
)
train_task_app = typer.Typer(
    cls=Group,
    help="Train a target model h with a logic loss (the paper's downstream tasks).",
    no_args_is_help=True,
)


def _version(value: bool) -> None:
    if value:
        ui.text(f"tleaf {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print version.")
    ] = False,
) -> None:
    """T-LEAF toolchain: LTLf rules -> DFAs -> embeddings -> logic losses."""


for name, function in {
    "compile-dfa": compile_dfa,
    "gen-formulas": gen_formulas,
    "gen-traces": gen_traces,
    "gen-activities": gen_activities,
    "read-log": read_log,
    "split-cases": split_cases,
    "mine-declare": mine_declare,
    "peer-formulas": peer_formulas,
    "check-cases": check_cases,
    "predict": predict,
    "task-graph": task_graph,
    "read-recordings": read_recordings,
    "check-recordings": check_recordings,
    "recording-activities": recording_activities,
    "recipe-formulas": recipe_formulas,
    "recording-traces": recording_traces,
    "kb-extract": kb_extract,
    "train-edge": train_edge,
    "train-meta": train_meta,
    "embed": embed,
    "gen-demos": gen_demos,
    "cooking-kb": cooking_kb,
    "demos-kb": demos_kb,
    "inspect": inspect,
}.items():
    app.command(name, cls=Command)(function)
for name, function in {
    "model-checking": eval_model_checking,
    "tsne": eval_tsne,
    "table": eval_table,
    "action-recognition": eval_action_recognition,
    "learning-curve": eval_learning_curve,
    "choose-lambda": eval_choose_lambda,
    "violations": eval_violations,
    "cooking": eval_cooking,
    "step-recognition": eval_step_recognition,
    "next-activity": eval_next_activity,
}.items():
    eval_app.command(name, cls=Command)(function)
for name, function in {
    "action-recognition": train_task_action_recognition,
    "cooking": train_task_cooking,
    "next-activity": train_task_next_activity,
}.items():
    train_task_app.command(name, cls=Command)(function)
app.add_typer(eval_app, name="eval")
app.add_typer(train_task_app, name="train-task")

# Python's collector runs a full collection whenever the objects that survived two collections
# have grown by a quarter: importing torch and building a run's data (objects that live for the
# whole command) cost about ten full collections, 0.9-1.5 s of each training or evaluation
# command. A young collection every 50,000 allocations instead of 700 leaves none of them;
# garbage with reference cycles is still collected, only later.
GC_THRESHOLDS = (50_000, 20, 20)


def main() -> None:
    """The `tleaf` entry point: the command line, with garbage collection spaced out."""
    gc.set_threshold(*GC_THRESHOLDS)
    app()
