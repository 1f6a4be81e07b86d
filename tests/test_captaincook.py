"""CaptainCook4D's recordings as `Cases` of `Recording`s and a `recordings` artifact
(data/captaincook.py), from small annotation files shaped like the dataset's, written here."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tleaf_cli.data.artifacts import read_provenance
from tleaf_cli.data.captaincook import (
    CaptainCookReader,
    Recording,
    load_recordings,
    read_recordings,
    write_recordings,
)
from tleaf_cli.data.case_readers import CaseReader
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.task_graphs import read_task_graph


def step(sid, start, end, text, err=False):
    return {
        "step_id": sid,
        "start_time": start,
        "end_time": end,
        "description": text,
        "has_errors": err,
    }


STEPS = {
    "1_1": {
        "recording_id": "1_1",
        "activity_id": 1,
        "activity_name": "Rice Bowl",
        "person_id": 1,
        "environment": 2,
        # out of time order in the file; the cook step has an error
        "steps": [
            step(2, 30.0, 40.0, "Cook -Cook the rice", True),
            step(3, 1.0, 20.0, "Rinse-Rinse the rice"),
            step(4, 50.0, 60.0, "Serve-Serve on a plate"),
        ],
    },
    "1_2": {
        "recording_id": "1_2",
        "activity_id": 1,
        "activity_name": "Rice Bowl",
        "steps": [
            step(3, -1, -1, "Rinse-Rinse the rice"),  # skipped by the person
            step(2, 5.0, 9.0, "Cook-Cook the rice"),
            step(7, 10.0, 11.0, "Dance-Dance"),  # not one of recipe 1's steps
            {"step_id": 4, "description": "Serve-Serve on a plate"},  # no times
        ],
    },
    "1_3": {"recording_id": "1_3", "activity_id": 1, "activity_name": "Rice Bowl", "steps": []},
}
ERRORS = [
    {
        "recording_id": "1_1",
        "activity_id": 1,
        "is_error": True,
        "step_annotations": [
            {"step_id": 2, "errors": [{"tag": "Timing Error", "description": "too long"}]},
        ],
    },
    {
        "recording_id": "1_2",
        "activity_id": 1,
        "is_error": True,
        "step_annotations": [
            {"step_id": 3, "errors": [{"tag": "Missing Step", "description": ""}]}
        ],
    },
]


@pytest.fixture()
def folder(tmp_path: Path) -> Path:
    out = tmp_path / "annotation_json"
    out.mkdir()
    (out / "complete_step_annotations.json").write_text(json.dumps(STEPS))
    (out / "error_annotations.json").write_text(json.dumps(ERRORS))
    (out / "activity_idx_step_idx.json").write_text(json.dumps({"1": [2, 3, 4]}))
    (tmp_path / "splits.json").write_text(json.dumps({"train": ["1_1"], "test": ["9_9"]}))
    return out


def test_rows_in_time_order_with_errors_and_splits(folder: Path, tmp_path: Path) -> None:
    report = read_recordings(folder, tmp_path / "splits.json")
    out = tmp_path / "recordings.parquet"
    write_recordings(report, out)
    rows = {r.recording_id: r for r in load_recordings(out)}
    assert set(rows) == {"1_1", "1_2"} and rows == {r.recording_id: r for r in report}
    one = rows["1_1"]
    assert isinstance(one, Recording) and one.case_id == "1_1"
    assert one.recipe == "ricebowl" and one.split == "train"
    assert one.step_ids == (3, 2, 4)
    assert one.start_s == (1.0, 30.0, 50.0) and one.end_s == (20.0, 40.0, 60.0)
    assert [t.timestamp() for t in one.timestamps] == [1.0, 30.0, 50.0]
    assert one.step_has_error == (False, True, False)
    assert one.step_error_categories == ((), ("Timing Error",), ())
    assert one.has_errors and one.error_categories == ("Timing Error",)
    two = rows["1_2"]
    assert two.split == "none" and two.step_ids == (2,) and two.skipped_step_ids == (3,)
    assert two.error_categories == ("Missing Step",)
    assert load_recordings(out).cases[0].row()["step_error_categories"] == [
        [],
        ["Timing Error"],
        [],
    ]
    assert report.skips.skipped == {
        "recordings without steps": 1,
        "steps with an unknown step_id": 1,
        "steps without times": 1,
        "split ids without a recording": 1,
    }
    prov = read_provenance(out)
    assert prov.kind == "recordings" and prov.params["skipped"] == report.skips.skipped
    assert prov.params["missing_files"] == []
    assert len(prov.inputs) == 4


def test_atoms_match_the_task_graph(folder: Path, tmp_path: Path) -> None:
    graph = tmp_path / "ricebowl.json"
    graph.write_text(
        json.dumps(
            {
                "steps": {"0": "START", "1": "Rinse-Rinse the rice", "2": "Cook-Cook the rice"},
                "edges": [[0, 1], [1, 2]],
            }
        )
    )
    atoms = set(read_task_graph(graph).atoms.values())
    rows = read_recordings(folder).cases
    assert {"rinse_rinse_the_rice", "cook_cook_the_rice"} <= atoms
    assert rows[0].atoms[:2] == ("rinse_rinse_the_rice", "cook_cook_the_rice")


def test_bad_files_name_the_file(folder: Path, tmp_path: Path) -> None:
    (folder / "error_annotations.json").write_text("[{")
    with pytest.raises(InputError, match=r"error_annotations\.json: not JSON"):
        read_recordings(folder)
    (tmp_path / "twice.json").write_text(json.dumps({"train": ["1_1"], "val": ["1_1"]}))
    (folder / "error_annotations.json").write_text("[]")
    with pytest.raises(InputError, match="recording 1_1 is in 'train' and 'val'"):
        read_recordings(folder, tmp_path / "twice.json")
    with pytest.raises(InputError, match="not a folder"):
        read_recordings(tmp_path / "nowhere")


def test_an_atomic_write_leaves_nothing_on_failure(folder: Path, tmp_path: Path) -> None:
    (folder / "complete_step_annotations.json").write_text(json.dumps({"x": {"steps": []}}))
    report = read_recordings(folder)
    out = tmp_path / "r.parquet"
    with pytest.raises(InputError, match="no recordings to write"):
        write_recordings(report, out)
    assert not out.exists()


def test_cli_summary_counts_splits_and_skips(folder: Path, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from tleaf_cli.cli import app

    out = tmp_path / "r.parquet"
    args = ["read-recordings", str(folder), "--splits", str(tmp_path / "splits.json")]
    result = CliRunner().invoke(app, [*args, "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "2 recordings (2 with errors; none 1, train 1)" in result.output
    assert "steps without times: 1" in result.output and out.exists()


def test_both_readers_implement_the_reader_interface(folder: Path) -> None:
    from tleaf_cli.data.log_readers import LogReader

    assert isinstance(CaptainCookReader(folder), CaseReader)
    assert isinstance(LogReader("log.csv"), CaseReader)


def _read_recordings_cli(folder: Path, out: Path, *args: str):
    from typer.testing import CliRunner

    from tleaf_cli.cli import app

    return CliRunner().invoke(app, ["read-recordings", str(folder), *args, "-o", str(out)])


@pytest.mark.parametrize("missing", ["error_annotations.json", "activity_idx_step_idx.json"])
def test_a_missing_annotation_file_is_warned_of_and_counted(
    folder: Path, tmp_path: Path, missing: str
) -> None:
    (folder / missing).unlink()
    out = tmp_path / "r.parquet"
    result = _read_recordings_cli(folder, out)
    assert result.exit_code == 0, result.output
    text = result.output.replace("\n", "")
    assert f"warning: 1 annotation file missing: {missing}" in text, result.output
    assert read_provenance(out).params["missing_files"] == [missing]


def test_a_recording_of_an_unknown_activity_id_is_skipped_and_counted(
    folder: Path, tmp_path: Path
) -> None:
    steps = dict(STEPS)
    steps["9_1"] = {**STEPS["1_1"], "recording_id": "9_1", "activity_id": 9}
    steps["x_1"] = {**STEPS["1_1"], "recording_id": "x_1", "activity_id": "one"}
    (folder / "complete_step_annotations.json").write_text(json.dumps(steps))
    out = tmp_path / "r.parquet"
    result = _read_recordings_cli(folder, out)
    assert result.exit_code == 0, result.output
    prov = read_provenance(out)
    assert prov.params["skipped"]["recordings with an unknown activity_id"] == 2
    assert prov.params["skipped_examples"]["recordings with an unknown activity_id"] == [
        "9_1 (activity_id 9)",
        "x_1 (activity_id 'one')",
    ]
    assert "2 recordings (2 with errors" in result.output
