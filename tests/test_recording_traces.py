"""recipe-formulas and recording-traces (real recordings as Table I test traces), on three of the
shipped CaptainCook4D recipes: the recorded traces' labels are check-recordings' verdicts and the
compiled recipe formula's, train and val are the synthetic traces, test only held-out recipes;
and the page section's arithmetic (pipelines/captaincook_table1.py)."""

from __future__ import annotations

import importlib.util
import json
import shutil
import sys
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.artifacts import write_artifact
from tleaf_cli.data.dfa_table import read_dfas
from tleaf_cli.data.traces import read_traces
from tleaf_cli.errors import InputError
from tleaf_cli.tasks.procedure_checks import read_recipe_rules, rule_files
from tleaf_cli.tasks.recording_traces import RECORDED, recipe_formulas, recording_traces

ROOT = Path(__file__).parent.parent
DATA = ROOT / "examples" / "captaincook4d"
# small graphs whose recordings both keep and break their rules
RECIPES = ("spicedhotchocolate", "microwavefrenchtoast", "tomatomozzarellasalad")


def _run(*args: object) -> None:
    result = CliRunner().invoke(app, [str(a) for a in args])
    assert result.exit_code == 0, result.output


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The chain of the pipeline's Table I stages up to recording-traces, on three recipes."""
    d = tmp_path_factory.mktemp("rt")
    (d / "graphs").mkdir()
    for r in RECIPES:
        shutil.copy(DATA / "task_graphs" / f"{r}.json", d / "graphs")
    p = {k: d / v for k, v in [("edges", "edges.ltl"), ("recipes", "recipes.ltl")]}
    p |= {k: d / f"{k}.parquet" for k in ("recordings", "dfas", "traces", "real")}
    _run("task-graph", d / "graphs", "-o", p["edges"], "-q")
    splits = DATA / "data_splits" / "recordings_data_split_combined.json"
    _run("read-recordings", DATA / "annotation_json", "--splits", splits, "-o", p["recordings"])
    _run("recipe-formulas", p["edges"], "-o", p["recipes"], "-q")
    _run("compile-dfa", p["recipes"], "--one-hot", "-o", p["dfas"], "-q")
    _run("gen-traces", p["dfas"], "--one-hot", "--per-formula", 4, "--split", "0.34,0.33,0.33",
         "-o", p["traces"], "-q")  # fmt: skip
    return p


@pytest.fixture(scope="module")
def traces(built: dict[str, Path]) -> dict[str, Path]:
    _run("recording-traces", built["recordings"], built["edges"], built["traces"], "-o",
         built["real"], "-q")  # fmt: skip
    return built


def test_a_recipe_formula_is_the_conjunction_of_its_rules(built: dict[str, Path]) -> None:
    rules = read_recipe_rules(rule_files(built["edges"]))
    formulas = recipe_formulas(built["edges"])
    assert sorted(formulas) == sorted(RECIPES)
    for recipe, formula in formulas.items():
        assert formula == " & ".join(f"({r.formula})" for r in rules[recipe])
    written = [
        line.split(":", 1)[0] for line in built["recipes"].read_text().splitlines() if ":" in line
    ]
    assert sorted(w for w in written if not w.startswith("#")) == sorted(RECIPES)


def test_recorded_labels_are_the_exact_checks_and_the_formulas(
    traces: dict[str, Path], tmp_path: Path
) -> None:
    synthetic = read_traces(traces["traces"]).to_pylist()
    split_of = {r["formula_id"]: r["split"] for r in synthetic}
    held_out = {f for f, s in split_of.items() if s == "test"}
    assert len(held_out) == 1
    rows = read_traces(traces["real"]).to_pylist()
    recorded = [r for r in rows if r["source"] == RECORDED]
    # train and val: the synthetic rows as they were; test: recordings of held-out recipes only
    assert [r for r in rows if r["source"] != RECORDED] == [
        r | {"recording_id": None} for r in synthetic if r["split"] != "test"
    ]
    assert {r["split"] for r in recorded} == {"test"}
    assert {r["formula_id"] for r in recorded} == held_out
    assert not any(r["split"] == "test" for r in rows if r["source"] != RECORDED)

    # every recording of the held-out recipe, labelled as check-recordings finds it
    _run("check-recordings", traces["recordings"], traces["edges"], "-o", tmp_path / "checks")
    checks = pq.read_table(tmp_path / "checks" / "checks.parquet").to_pylist()
    expected = {
        c["recording_id"]: not c["broken_rules"]
        for c in checks
        if c["recipe"] in held_out and c["checked"]
    }
    got = {r["recording_id"]: r["label"] for r in recorded}
    assert got == expected
    assert set(got.values()) == {True, False}  # both kinds present: the labels can be wrong

    # and as the compiled conjunction (the formula eval model-checking embeds) reads them
    dfas = read_dfas(traces["dfas"])
    for r in recorded:
        assert dfas.dfa(r["formula_id"]).accepts([set(x) for x in r["trace"]]) == r["label"]


def test_recording_traces_refuses_traces_without_a_split_or_test_recipe(
    traces: dict[str, Path], tmp_path: Path
) -> None:
    plain = tmp_path / "plain.parquet"
    _run("gen-traces", traces["dfas"], "--one-hot", "--per-formula", 2, "-o", plain, "-q")
    with pytest.raises(InputError, match="no split column"):
        recording_traces(traces["recordings"], traces["edges"], plain, tmp_path / "out.parquet")
    no_test = tmp_path / "no_test.parquet"
    _run("gen-traces", traces["dfas"], "--one-hot", "--per-formula", 2, "--split", "0.7,0.3,0",
         "-o", no_test, "-q")  # fmt: skip
    with pytest.raises(InputError, match="no test recipe"):
        recording_traces(traces["recordings"], traces["edges"], no_test, tmp_path / "o.parquet")
    assert not (tmp_path / "out.parquet").exists() and not (tmp_path / "o.parquet").exists()


def _report_script():
    spec = importlib.util.spec_from_file_location(
        "captaincook_table1", ROOT / "pipelines" / "captaincook_table1.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_the_section_reads_keeping_and_breaking_recordings_apart(tmp_path: Path) -> None:
    script = _report_script()
    # 4 keep, 6 break; 3 keeping and 2 breaking recordings recognised: all 5 / 10
    scores = script.real_scores({"accuracy": 0.75, "all_accuracy": 0.5}, 4, 6)
    assert scores["accuracy"] == pytest.approx(50.0)
    assert scores["keep"] == pytest.approx(75.0)
    assert scores["break"] == pytest.approx(100 * 2 / 6)
    assert scores["balanced"] == pytest.approx((75.0 + 100 * 2 / 6) / 2)

    page = "# title\n\nbefore\n"
    start, end = script.markers(tmp_path / "table1")
    once = script.splice(page, f"{start}\nA\n{end}\n", start, end)
    twice = script.splice(once + "after\n", f"{start}\nB\n{end}\n", start, end)
    assert once.startswith(page.rstrip("\n")) and "A" in once
    assert "A\n" not in twice and "B" in twice and twice.endswith("after\n")


def test_the_section_from_reports(tmp_path: Path) -> None:
    """The table's cells, the gap and the goal from hand-made reports and recorded traces."""
    script = _report_script()
    t1 = tmp_path / "table1"
    t1.mkdir()
    (t1 / "recipes.ltl").write_text("r: a\n")
    empty = pa.table({"formula_id": pa.array([], pa.string())})
    write_artifact(
        empty, t1 / "traces.parquet", kind="traces", schema=1, params={"once_each": True}, inputs=[]
    )
    labels = [True, True, False, False, False]
    pq.write_table(
        pa.table({"formula_id": ["r"] * 5, "label": labels, "split": ["test"] * 5}),
        t1 / "recording_traces.parquet",
    )
    cells = {
        ("best", "real"): {"accuracy": 1.0, "all_accuracy": 0.8},
        ("best", "synthetic"): {"accuracy": 0.9, "all_accuracy": 0.5},  # Table I's: accuracy
        ("paper", "real"): {"accuracy": 0.5, "all_accuracy": 0.6},
        ("paper", "synthetic"): {"accuracy": 0.7, "all_accuracy": 0.7},
    }
    for (preset, data), mlp in cells.items():
        folder = t1 / "seed0" / f"eval-{preset}-{data}"
        folder.mkdir(parents=True)
        distance = {"accuracy": 0.3, "all_accuracy": 0.4}
        (folder / "report.json").write_text(json.dumps({"mlp": mlp, "distance": distance}))
    text = script.section(t1, "make x")
    rows = {line.split(" | ")[0]: line for line in text.splitlines() if line.startswith("| ")}
    # best: real 80, keep 100, break 2/3, synthetic 90: -10 points, not met
    assert "| 80.0 | 100.0 | 66.7 | 83.3 | 90.0 | -10.0 | not met | 40.0 / 30.0 |" in rows["| best"]
    # paper: real 60, keep 50, break (3 - 1) / 3, synthetic 70: -10 points
    assert "| 60.0 | 50.0 | 66.7 | 58.3 | 70.0 | -10.0 | not met |" in rows["| paper"]
    assert "60.0 %" in text  # always answering the larger class: 3 of 5
    assert "larger class (60.0 %) on the real recordings: best." in text  # 80 > 60, paper's 60 not
    assert "exactly once" in text and text.startswith("<!-- captaincook-table1 -->")
