"""Attributes read as inputs (`train-task next-activity --inputs / --numeric-inputs`): their
encoding (inputs.py) and, end to end, a model that needs them to know what comes next."""

from __future__ import annotations

import json
import random
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tleaf_cli.cli.root import app
from tleaf_cli.data.cases import Case
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.errors import InputError
from tleaf_cli.settings.next_activity import NextActivitySettings
from tleaf_cli.tasks.next_activity.encoding import TIME_FEATURES, Encoder
from tleaf_cli.tasks.next_activity.inputs import AttributeInput, extend_columns, input_columns

runner = CliRunner()


def _log(path: Path, cases: int = 240, seed: int = 0) -> Path:
    """A CSV log where what follows `a` is told only by an attribute: the case's `kind` (x: b,
    y: c) and, apart from it, the lab value on `a` (over 50: d, else e); `unit` is noise."""
    rng = random.Random(seed)
    rows = ["case:concept:name,concept:name,time:timestamp,kind,lab,unit"]
    for i in range(cases):
        kind, lab = rng.choice("xy"), rng.uniform(0, 100)
        events = [("a", f"{lab:.2f}"), ("b" if kind == "x" else "c", ""), ("z", "")]
        events.append(("d" if lab > 50 else "e", ""))
        for t, (act, value) in enumerate(events):
            day = 1 + i % 28
            unit = rng.choice(["u1", "u2"])
            rows.append(f"k{i},{act},2020-01-{day:02d}T{10 + t:02d}:00:00,{kind},{value},{unit}")
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def cases_path(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("inputs")
    out = folder / "cases.parquet"
    result = runner.invoke(
        app,
        ["read-log", str(_log(folder / "log.csv")), "--attributes", "lab,unit",
         "--case-attributes", "kind", "-o", str(out), "-q"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    return out


def _case(values, kind="x") -> Case:
    n = len(values)
    return Case(
        "c1",
        tuple("a" * n),
        tuple("a" * n),
        tuple(np.datetime64("2020-01-01") for _ in range(n)),
        "train",
        attributes={"lab": tuple(values)},
        case_attributes={"kind": kind},
    )


def test_numeric_inputs_are_normalised_on_train_with_a_missing_flag():
    lab = AttributeInput.fit("lab", "numeric", [_case(["1", "3", None]), _case(["5"])])
    assert lab.mean == pytest.approx(3.0) and lab.scale == pytest.approx(np.std([1, 3, 5]))
    cols = lab.encode(["3", None, "7"])
    assert cols[:, 1].tolist() == [0.0, 1.0, 0.0]  # the flag where there is no value
    assert cols[0, 0] == pytest.approx(0.0) and cols[2, 0] == pytest.approx(4 / lab.scale)
    with pytest.raises(InputError, match=r"case 'c1', event 2: lab is 'high', not a finite"):
        AttributeInput.fit("lab", "numeric", [_case(["1", "high"])])


def test_categorical_inputs_keep_the_most_frequent_values_and_one_column_for_the_rest():
    cases = [_case(["v1", "v1", "v1", "v2"])] + [_case([f"w{i}", f"w{i}"]) for i in range(40)]
    unit = AttributeInput.fit("lab", "categorical", cases)
    assert len(unit.values) == 32 and "v1" in unit.values and "v2" not in unit.values
    cols = unit.encode(["v1", "v2", None])
    assert cols.sum(axis=1).tolist() == [1.0, 1.0, 0.0]
    assert cols[0, unit.values.index("v1")] == 1.0 and cols[1, -1] == 1.0  # the rest


def test_appended_events_keep_the_case_attributes_and_have_no_event_values():
    kind = AttributeInput.fit("case:kind", "categorical", [_case(["1"], "x"), _case(["2"], "y")])
    lab = AttributeInput.fit("lab", "numeric", [_case(["1"]), _case(["3"])])
    inputs = (kind, lab)
    known = input_columns(inputs, _case(["3", "1"], "y"))
    assert known.shape == (2, kind.width + lab.width)
    assert known[:, kind.values.index("y")].tolist() == [1.0, 1.0]  # every event reads it
    longer = extend_columns(inputs, known, 4)
    assert (longer[2:, : kind.width] == known[1, : kind.width]).all()
    assert longer[2:, kind.width + 1].tolist() == [1.0, 1.0]  # lab: none, flagged


def test_the_encoder_keeps_its_inputs_through_its_config(cases_path):
    cases = read_cases(cases_path)
    encoder = Encoder.fit(cases, inputs=["case:kind", "unit"], numeric_inputs=["lab"])
    assert encoder.feature_count == TIME_FEATURES + (2 + 1) + (2 + 1) + 2
    again = Encoder.from_dict(json.loads(json.dumps(encoder.as_dict())))
    assert again == encoder
    case = cases.cases[0]
    x = again.features(again.indices(case).tolist(), case.timestamps, again.input_columns(case))
    assert x.shape == (len(case), encoder.feature_count)
    with pytest.raises(InputError, match="keeps no case attribute 'colour'"):
        Encoder.fit(cases, inputs=["case:colour"])
    bare = Case(case.case_id, case.activities, case.atoms, case.timestamps, "test")
    with pytest.raises(InputError, match=r"keeps no case attribute 'kind', which the model"):
        again.input_columns(bare)


def test_settings_refuse_an_attribute_read_twice_and_inputs_to_the_prefix_table():
    from tleaf_cli.errors import SettingError

    with pytest.raises(SettingError, match="already read"):
        NextActivitySettings(inputs="lab", numeric_inputs="lab").check()
    with pytest.raises(SettingError, match="prefix table"):
        NextActivitySettings(model="prefix-table", numeric_inputs="lab").check()


@pytest.mark.parametrize("model", ["lstm", "transformer"])
def test_a_model_reading_the_attributes_learns_what_they_tell(tmp_path, cases_path, model):
    """What follows `a` is a coin flip without the attributes and certain with them."""

    def accuracy(*options: str) -> float:
        out = tmp_path / f"run{len(options)}"
        result = runner.invoke(
            app,
            ["train-task", "next-activity", str(cases_path), "--model", model, "--hidden", "32",
             "--layers", "1", "--epochs", "60", "--patience", "60", "--lr", "0.01",
             *options, "-o", str(out), "-q"],
        )  # fmt: skip
        assert result.exit_code == 0, result.output
        evaluated = runner.invoke(
            app,
            ["eval", "next-activity", str(out), str(cases_path), "--prefix-lengths", "1",
             "-o", str(out / "e"), "-q"],
        )  # fmt: skip
        assert evaluated.exit_code == 0, evaluated.output
        metrics = json.loads((out / "e" / "metrics.json").read_text())
        suffixes.append(metrics["suffix"]["1"]["beam"]["dl_similarity"])
        return metrics["accuracy"]["accuracy"]

    suffixes: list[float] = []

    without = accuracy()
    with_inputs = accuracy("--inputs", "case:kind,unit", "--numeric-inputs", "lab")
    # 5 targets a case, 2 of them coin flips without the attributes: ~0.8 against ~1.0
    assert without < 0.9
    assert with_inputs > without + 0.1
    # the suffix search reads them too: after `a` the rest is told by the attributes alone
    assert suffixes[1] > suffixes[0]


def test_an_input_the_cases_do_not_keep_is_named_with_those_of_its_scope(cases_path):
    """Before: `case:nope` was answered "it keeps: lab, unit, case:kind", event attributes
    first, and with no case attribute kept only event attributes, as if they were the case's."""
    cases = read_cases(cases_path)
    with pytest.raises(InputError) as case:
        Encoder.fit(cases, inputs=["case:nope"])
    said = str(case.value)
    assert (
        "keeps no case attribute 'nope' (case attributes: case:kind; event attributes: lab, unit)"
        in said
    )
    with pytest.raises(InputError) as event:
        Encoder.fit(cases, numeric_inputs=["nope"])
    assert "(event attributes: lab, unit; case attributes: case:kind)" in str(event.value)
