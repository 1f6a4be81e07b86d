"""Artifacts open in the tools the README names (pandas, duckdb), provenance included."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tleaf_cli.data.compile_dfas import CompileSettings, compile_file


def test_a_dfa_artifact_opens_in_pandas_and_duckdb(tmp_path: Path) -> None:
    pd = pytest.importorskip("pandas")
    duckdb = pytest.importorskip("duckdb")
    rules = tmp_path / "rules.ltl"
    rules.write_text("never_cut_milk: G !cut_milk\nrinse_first: (!cook U rinse) | G !cook\n")
    out = tmp_path / "dfas.parquet"
    compile_file(rules, out, CompileSettings(alphabet="one-hot", cache_dir=None))
    frame = pd.read_parquet(out)
    assert list(frame["formula_id"]) == ["never_cut_milk", "rinse_first"]
    assert frame["error"].isna().all() and (frame["num_states"] >= 2).all()
    con = duckdb.connect()
    rows = con.execute(
        f"select formula_id, num_states, len(edges) from read_parquet('{out}') order by formula_id"
    ).fetchall()
    assert [r[0] for r in rows] == ["never_cut_milk", "rinse_first"]
    assert rows == [(i, n, len(e)) for i, n, e in zip(
        frame["formula_id"], frame["num_states"], frame["edges"], strict=True
    )]  # fmt: skip
    meta = con.execute(
        f"select value from parquet_kv_metadata('{out}') where key = 'tleaf.inputs'"
    ).fetchone()
    inputs = json.loads(bytes(meta[0]).decode())
    assert Path(inputs[0]["path"]) == rules.resolve()  # recorded absolute
