"""split-cases --train-share F: a seeded draw of F of the training cases stays train, the others
become `unused`; val and test are the fold's; a smaller share's cases are among a larger one's
for one seed; at least one case; bad shares refused with one line."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.artifacts import read_provenance
from tleaf_cli.data.case_folds import split_anew
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.data.train_share import UNUSED, keep_train_share, train_share_size
from tleaf_cli.errors import SettingError
from tleaf_cli.settings.event_logs import FoldSettings

runner = CliRunner()
CASES = 60  # fold 0 of 5, val 0.2: 48 training cases of which 38 train, 10 val; 12 test


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def cases(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("share")
    rows = ["case_id,activity,timestamp"]
    for n in range(CASES):
        for step in range(2 + n % 3):
            rows.append(f"{n},act{(n + step) % 4},2020-02-{1 + n % 28:02d} 09:{step:02d}:00")
    log = folder / "log.csv"
    log.write_text("\n".join(rows) + "\n", encoding="utf-8")
    out = folder / "cases.parquet"
    result = tleaf("read-log", log, "-o", out, "--quiet")
    assert result.exit_code == 0, result.output
    return out


def _splits(path: Path) -> dict[str, str]:
    return {c.case_id: c.split for c in read_cases(path).cases}


def _ids(split_of: dict[str, str], split: str) -> set[str]:
    return {c for c, s in split_of.items() if s == split}


def test_a_share_keeps_that_share_of_train_and_leaves_val_and_test_as_the_fold_has_them(
    cases: Path, tmp_path: Path
) -> None:
    whole = tmp_path / "whole.parquet"
    split_anew(cases, whole, FoldSettings(fold=0))
    full = _splits(whole)
    train = _ids(full, "train")
    assert len(train) == 38
    part = tmp_path / "part.parquet"
    counts = split_anew(cases, part, FoldSettings(fold=0, train_share=0.25, share_seed=1))
    got = _splits(part)
    assert counts["train"] == round(0.25 * 38) == 10 and counts[UNUSED] == 28
    assert _ids(got, "train") < train  # drawn from the fold's training cases
    assert _ids(got, UNUSED) == train - _ids(got, "train")
    for split in ("val", "test"):
        assert _ids(got, split) == _ids(full, split)
    # only the split changes: the same cases, activities and atom map
    old, new = read_cases(whole), read_cases(part)
    assert [(c.case_id, c.activities) for c in new.cases] == [
        (c.case_id, c.activities) for c in old.cases
    ]
    assert new.activity_atoms == old.activity_atoms
    params = read_provenance(part).params
    assert (params["train_share"], params["share_seed"]) == (0.25, 1)


def test_shares_of_one_seed_are_nested_and_seeds_draw_other_cases(
    cases: Path, tmp_path: Path
) -> None:
    drawn = {}
    for seed in (0, 1):
        for share in (0.05, 0.1, 0.3, 0.6, 1.0):
            out = tmp_path / f"s{seed}-{share}.parquet"
            split_anew(cases, out, FoldSettings(fold=0, train_share=share, share_seed=seed))
            drawn[seed, share] = _ids(_splits(out), "train")
    for seed in (0, 1):
        sizes = [len(drawn[seed, s]) for s in (0.05, 0.1, 0.3, 0.6, 1.0)]
        assert sizes == [2, 4, 11, 23, 38]
        for small, large in [(0.05, 0.1), (0.1, 0.3), (0.3, 0.6), (0.6, 1.0)]:
            assert drawn[seed, small] <= drawn[seed, large]
    assert drawn[0, 0.3] != drawn[1, 0.3]
    again = tmp_path / "again.parquet"
    split_anew(cases, again, FoldSettings(fold=0, train_share=0.3, share_seed=0))
    assert _ids(_splits(again), "train") == drawn[0, 0.3]  # the same seed draws the same cases


def test_a_tiny_share_keeps_one_case_and_share_one_changes_nothing() -> None:
    split_of = {f"c{i}": "train" for i in range(7)} | {"v": "val", "t": "test"}
    ids = list(split_of)
    tiny = keep_train_share(split_of, ids, 0.01, 0)
    assert sum(s == "train" for s in tiny.values()) == 1
    assert sum(s == UNUSED for s in tiny.values()) == 6
    assert (tiny["v"], tiny["t"]) == ("val", "test")
    assert keep_train_share(split_of, ids, 1.0, 3) == split_of
    assert train_share_size(0, 0.5) == 0
    assert [train_share_size(200, f) for f in (0.001, 0.01, 0.5, 1)] == [1, 2, 100, 200]


@pytest.mark.parametrize("share", [0, -0.5, 1.5, math.nan, math.inf, True])
def test_the_library_refuses_a_share_outside_zero_to_one(share: float) -> None:
    with pytest.raises(SettingError, match="train_share"):
        FoldSettings(fold=0, train_share=share).check()
    with pytest.raises(SettingError, match="above 0 and at most 1"):
        train_share_size(10, share)


def test_the_command_line_writes_the_share_and_says_so(cases: Path, tmp_path: Path) -> None:
    out = tmp_path / "cli.parquet"
    result = tleaf("split-cases", cases, "-o", out, "--fold", 0, "--train-share", "0.1")
    assert result.exit_code == 0, result.output
    assert "4 train, 10 val, 12 test, 34 unused" in result.output
    assert sorted(set(_splits(out).values())) == ["test", "train", "unused", "val"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--train-share", "0"], "--train-share: must be a share above 0 and at most 1, not 0.0"),
        (["--train-share", "1.01"], "--train-share: must be a share above 0 and at most 1"),
        (["--train-share", "nan"], "--train-share: must be a share above 0 and at most 1, not nan"),
        (["--train-share", "-1"], "--train-share: must be a share above 0 and at most 1"),
        (["--share-seed", "3"], "--share-seed: only with --train-share below 1"),
    ],
)
def test_a_bad_share_exits_2_with_one_line_and_writes_nothing(
    cases: Path, tmp_path: Path, args: list[str], message: str
) -> None:
    out = tmp_path / "bad.parquet"
    result = tleaf("split-cases", cases, "-o", out, "--fold", 0, *args)
    assert result.exit_code == 2, result.output
    assert message in result.output and "Traceback" not in result.output
    assert not out.exists()
    assert len(result.output.strip().splitlines()) == 1, result.output
