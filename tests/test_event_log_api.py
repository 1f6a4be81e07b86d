"""The event-log side of the Python API: tl.read_log (a file, a cases artifact, or a DataFrame
with pm4py's column names), tl.read_rules (names matched to the log's), tl.check_cases, each
equal to the commands and strict about its arguments."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

import tleaf_cli as tl
from tleaf_cli.cli import app
from tleaf_cli.errors import ArgumentError, ArgumentTypeError, InputError

ROOT = Path(__file__).resolve().parent.parent
LOG = ROOT / "examples" / "event_logs" / "helpdesk-400.csv"
MODEL = ROOT / "examples" / "helpdesk.decl"


def test_a_pm4py_dataframe_reads_as_the_log_and_checks_as_the_command(tmp_path: Path) -> None:
    frame = pd.read_csv(LOG)
    frame["time:timestamp"] = pd.to_datetime(frame["time:timestamp"])
    cases = tl.read_log(frame)
    from_file = tl.read_log(LOG)
    assert [(c.case_id, c.activities) for c in cases] == [
        (c.case_id, c.activities) for c in from_file
    ]
    table = tl.check_cases(cases, tl.read_rules(MODEL, cases))
    artifact = tmp_path / "cases.parquet"
    assert CliRunner().invoke(app, ["read-log", str(LOG), "-o", str(artifact), "-q"]).exit_code == 0
    out = tmp_path / "checks.parquet"
    done = CliRunner().invoke(app, ["check-cases", str(artifact), str(MODEL), "-o", str(out), "-q"])
    assert done.exit_code == 0, done.output
    command = pq.read_table(out).to_pandas()
    by_command = {(r.case_id, r.rule): r.satisfied for r in command.itertuples()}
    assert {(r.case_id, r.rule): r.satisfied for r in table.itertuples()} == by_command
    assert 0 < table.satisfied.mean() < 1


def test_a_cases_artifact_reads_back(tmp_path: Path) -> None:
    artifact = tmp_path / "cases.parquet"
    CliRunner().invoke(app, ["read-log", str(LOG), "-o", str(artifact), "-q"])
    assert len(tl.read_log(artifact)) == len(tl.read_log(LOG)) == 400


@pytest.mark.parametrize(
    ("call", "error", "argument"),
    [
        (lambda: tl.read_log(3), ArgumentTypeError, "source"),
        (lambda: tl.read_log(pd.DataFrame({"case": [1]})), ArgumentError, "source"),
        (lambda: tl.read_log(LOG, attributes="org:resource"), ArgumentTypeError, "attributes"),
        (lambda: tl.read_rules(MODEL, cases=[1]), ArgumentTypeError, "cases"),
        (lambda: tl.check_cases(tl.read_log(LOG), []), ArgumentError, "rules"),
        (lambda: tl.check_cases("cases", []), ArgumentTypeError, "cases"),
    ],
)
def test_arguments_are_checked(call, error, argument: str) -> None:
    with pytest.raises(error) as caught:
        call()
    assert caught.value.argument == argument


def test_a_missing_file_names_it() -> None:
    with pytest.raises(InputError, match=r"nope\.csv"):
        tl.read_log("nope.csv")


def test_a_run_predicts_from_a_dataframe_as_the_command_does(tmp_path: Path) -> None:
    """tl.read_log of a pm4py DataFrame, tl.load_run, .predict: the rows of `tleaf predict`
    on the same cases (the artifact's test split), to the digit (the split column aside: a
    DataFrame read here is one split)."""
    artifact = tmp_path / "cases.parquet"
    runner = CliRunner()
    assert runner.invoke(app, ["read-log", str(LOG), "-o", str(artifact), "-q"]).exit_code == 0
    run = tmp_path / "run"
    trained = runner.invoke(
        app,
        ["train-task", "next-activity", str(artifact), "-o", str(run), "--epochs", "2",
         "--hidden", "8", "--layers", "1", "-q"],
    )  # fmt: skip
    assert trained.exit_code == 0, trained.output
    out = tmp_path / "predictions.parquet"
    args = ["--rules", str(MODEL), "--prefix-lengths", "1-2", "--samples", "20", "--split", "test"]
    done = runner.invoke(app, ["predict", str(run), str(artifact), "-o", str(out), *args, "-q"])
    assert done.exit_code == 0, done.output
    command = pq.read_table(out).to_pandas()
    frame = pd.read_csv(LOG)
    frame = frame[frame["case:concept:name"].isin(set(command.case_id))]
    frame["time:timestamp"] = pd.to_datetime(frame["time:timestamp"])
    got = tl.load_run(run, rules=MODEL, samples=20).predict(
        tl.read_log(frame), prefix_lengths="1-2"
    )
    key = ["case_id", "prefix_length"]
    got = got.sort_values(key).reset_index(drop=True)
    command = command.sort_values(key).reset_index(drop=True)
    assert len(got) == len(command) > 40
    for column in command.columns.drop("split"):
        assert got[column].astype(str).tolist() == command[column].astype(str).tolist(), column
