"""split-cases: a cases artifact split anew by the published protocols. KFold's folds (the ids
scikit-learn's KFold gives, validation the last share of each training fold), Tax et al.'s thirds
(as their code counts them), the input left as it was, and the refusals."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from sklearn.model_selection import KFold
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.artifacts import file_sha256, read_provenance
from tleaf_cli.data.case_folds import id_order, split_anew, thirds_splits
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.errors import SettingError
from tleaf_cli.settings.event_logs import FoldSettings

runner = CliRunner()
CASES = 23  # not a multiple of 5 or 3: the folds and thirds are uneven


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def cases(tmp_path_factory) -> Path:
    """A cases artifact of 23 cases whose integer ids are in no order in the file."""
    folder = tmp_path_factory.mktemp("folds")
    ids = [str(7 * k + 3) for k in range(CASES)]
    random.Random(5).shuffle(ids)
    rows = ["case_id,activity,timestamp"]
    for n, case in enumerate(ids):
        for step in range(1 + n % 4):
            rows.append(f"{case},act{(n + step) % 5},2020-01-{1 + n % 28:02d} 10:{step:02d}:00")
    log = folder / "log.csv"
    log.write_text("\n".join(rows) + "\n", encoding="utf-8")
    out = folder / "cases.parquet"
    result = tleaf("read-log", log, "-o", out, "--quiet")
    assert result.exit_code == 0, result.output
    return out


def _splits(path: Path) -> dict[str, str]:
    return {c.case_id: c.split for c in read_cases(path).cases}


@pytest.mark.parametrize("order", ["id", "file"])
def test_the_folds_are_sklearns_kfold_with_the_last_share_of_training_as_val(
    cases: Path, tmp_path: Path, order: str
) -> None:
    ids = [c.case_id for c in read_cases(cases).cases]
    given = id_order(ids) if order == "id" else ids
    tests = []
    for fold, (train, test) in enumerate(
        KFold(n_splits=5, shuffle=True, random_state=42).split(given)
    ):
        out = tmp_path / f"fold{fold}.parquet"
        result = tleaf("split-cases", cases, "-o", out, "--fold", fold, "--case-order", order)
        assert result.exit_code == 0, result.output
        split = _splits(out)
        keep = round(len(train) * 0.8)
        assert [given[i] for i in train[:keep]] == [c for c in given if split[c] == "train"]
        assert [given[i] for i in train[keep:]] == [c for c in given if split[c] == "val"]
        assert {given[i] for i in test} == {c for c in ids if split[c] == "test"}
        tests.append({c for c in ids if split[c] == "test"})
    assert sorted(c for t in tests for c in t) == sorted(ids)  # the test sets partition the cases


def test_id_order_sorts_integer_ids_as_numbers_and_other_ids_as_text() -> None:
    assert id_order(["10", "9", "100"]) == ["9", "10", "100"]
    assert id_order(["Case 10", "Case 9"]) == ["Case 10", "Case 9"]


def test_the_new_artifact_changes_only_the_split_and_leaves_its_input_as_it_was(
    cases: Path, tmp_path: Path
) -> None:
    before = file_sha256(cases)
    out = tmp_path / "fold.parquet"
    counts = split_anew(cases, out, FoldSettings(fold=3, seed=7, val=0.25))
    assert file_sha256(cases) == before
    old, new = read_cases(cases), read_cases(out)
    strip = [(c.case_id, c.activities, c.atoms, c.timestamps) for c in old.cases]
    assert [(c.case_id, c.activities, c.atoms, c.timestamps) for c in new.cases] == strip
    assert new.activity_atoms == old.activity_atoms
    assert sum(counts.values()) == CASES and counts["test"] in (4, 5)
    prov = read_provenance(out)
    assert prov.kind == "cases"
    assert {k: prov.params[k] for k in ("protocol", "folds", "fold", "seed", "val")} == {
        "protocol": "kfold",
        "folds": 5,
        "fold": 3,
        "seed": 7,
        "val": 0.25,
    }
    assert prov.params["source"]["split"] == list(old.params["split"])
    assert [i["sha256"] for i in prov.inputs] == [before]


@pytest.mark.parametrize(
    ("n", "test"),
    # Tax et al.'s code: the first 2 * round((n + 1) / 3) cases train, the rest test
    [(3804, 1268), (9658, 3218), (937, 311), (911, 303), (7554, 2518), (4, 0), (5, 1)],
)
def test_thirds_take_the_cases_tax_et_al_s_code_takes(n: int, test: int) -> None:
    ids = [f"c{i}" for i in range(n)]
    split = thirds_splits(ids, 0.2)
    assert [split[c] for c in ids[n - test :]] == ["test"] * test
    trained = ids[: n - test]
    keep = round(len(trained) * 0.8)
    assert [split[c] for c in trained] == ["train"] * keep + ["val"] * (len(trained) - keep)


def test_thirds_through_the_command_line(cases: Path, tmp_path: Path) -> None:
    out = tmp_path / "thirds.parquet"
    result = tleaf("split-cases", cases, "-o", out, "--protocol", "thirds")
    assert result.exit_code == 0, result.output
    splits = [c.split for c in read_cases(out).cases]  # file order
    # 2 * round(24 / 3) = 16 cases train and val (the last 20 %: 3 of them), 7 test
    assert splits == ["train"] * 13 + ["val"] * 3 + ["test"] * 7


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--fold", "5"], "--fold: must be 0 to 4"),
        (["--folds", "3", "--fold", "3"], "--fold: must be 0 to 2"),
        ([], "--fold: is required"),
        (["--fold", "0", "--folds", "24"], "--folds: must be at most the 23 cases"),
        (["--fold", "0", "--val", "1"], "--val: must be at least 0 and below 1"),
        (["--fold", "0", "--val", "-0.1"], "--val"),
        (["--protocol", "thirds", "--fold", "1"], "--fold: only with --protocol kfold"),
    ],
)
def test_a_bad_call_exits_2_with_one_line_and_writes_nothing(
    cases: Path, tmp_path: Path, args: list[str], message: str
) -> None:
    out = tmp_path / "out.parquet"
    result = tleaf("split-cases", cases, "-o", out, *args)
    assert result.exit_code == 2, result.output
    assert message in result.output and "Traceback" not in result.output
    assert not out.exists()


def test_it_refuses_to_overwrite_its_input_and_reads_only_cases_artifacts(
    cases: Path, tmp_path: Path
) -> None:
    before = file_sha256(cases)
    result = tleaf("split-cases", cases, "-o", cases, "--fold", 0)
    assert result.exit_code == 2 and "is also an input" in result.output, result.output
    assert file_sha256(cases) == before
    text = tmp_path / "log.csv"
    text.write_text("case,activity,timestamp\n", encoding="utf-8")
    result = tleaf("split-cases", text, "-o", tmp_path / "x.parquet", "--fold", 0)
    assert result.exit_code == 2 and str(text) in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1


def test_the_library_refuses_more_folds_than_cases(cases: Path, tmp_path: Path) -> None:
    with pytest.raises(SettingError, match="at most the 23 cases"):
        split_anew(cases, tmp_path / "x.parquet", FoldSettings(folds=30, fold=0))
    assert not (tmp_path / "x.parquet").exists()
