"""read-log's bad input refused by name, and its progress: a NaN in --split, a NUL in a name, a CSV
row with a field more than its header, `read_cases` given no path; the reader's progress
callback, which read-log draws as a bar."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.data.log_readers import read_log
from tleaf_cli.errors import InputError, SettingError, TleafError
from tleaf_cli.settings.event_logs import LogSettings

HEADER = "CaseID,ActivityID,CompleteTimestamp\n"
runner = CliRunner()


def _csv(tmp_path: Path, rows: str, name: str = "l.csv") -> Path:
    path = tmp_path / name
    path.write_text(HEADER + rows, encoding="utf-8")
    return path


def _read_log_cli(*args: object):
    return runner.invoke(app, ["read-log", *map(str, args)])


@pytest.mark.parametrize("split", ["nan,0.5,0.5", "0.5,nan,0.5", "0.5,0.5,nan", "inf,0,0"])
def test_a_split_with_nan_exits_2_naming_split(tmp_path: Path, split: str) -> None:
    log = _csv(tmp_path, "".join(f"{i},a,2020-01-01\n" for i in range(4)))
    out = tmp_path / "c.parquet"
    result = _read_log_cli(log, "-o", out, "--split", split)
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "--split" in lines[0] and "fractions" in lines[0], result.output
    assert "Traceback" not in result.output and not out.exists()
    with pytest.raises(SettingError, match="split"):
        LogSettings(split=tuple(float(x) for x in split.split(","))).check()


@pytest.mark.parametrize("where", ["activity", "case"])
def test_a_nul_in_a_name_is_refused_naming_the_line(tmp_path: Path, where: str) -> None:
    row = "2,a\x00b,2020-01-02\n" if where == "activity" else "2\x00x,b,2020-01-02\n"
    log = _csv(tmp_path, "1,a,2020-01-01\n" + row)
    with pytest.raises(InputError, match=rf"l\.csv: line 3: .*NUL.*{where}"):
        read_log(log)
    out = tmp_path / "c.parquet"
    result = _read_log_cli(log, "-o", out)
    assert result.exit_code == 2 and "line 3" in result.output, result.output
    assert "\x00" not in result.output and "\\x00" in result.output
    assert len(result.output.strip().splitlines()) == 1 and not out.exists()


def test_a_csv_row_with_an_extra_field_is_refused_naming_the_row(tmp_path: Path) -> None:
    log = _csv(tmp_path, "1,a,2020-01-01\n2,b,2020-01-02,surprise\n")
    with pytest.raises(InputError, match=r"l\.csv: line 3: 4 fields where the header has 3"):
        read_log(log)
    result = _read_log_cli(log, "-o", tmp_path / "c.parquet")
    assert result.exit_code == 2 and "line 3: 4 fields" in result.output, result.output


@pytest.mark.parametrize("name", ["l.csv", "l.csv.gz"])
def test_read_log_reports_progress_to_the_end(tmp_path: Path, name: str) -> None:
    log = _csv(tmp_path, "".join(f"{i},a,2020-01-01\n" for i in range(50)), name)
    if name.endswith(".gz"):
        import gzip

        log.write_bytes(gzip.compress(log.read_bytes()))
    calls: list[tuple[int, int]] = []
    cases = read_log(log, progress=lambda done, total: calls.append((done, total)))
    assert len(cases.cases) == 50
    assert calls and calls[-1][0] == calls[-1][1] == log.stat().st_size, calls
    assert all(done <= total for done, total in calls)


def test_read_cases_without_a_path_is_a_tleaf_error() -> None:
    with pytest.raises(TleafError, match="path"):
        read_cases(None)  # type: ignore[arg-type]
