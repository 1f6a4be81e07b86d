"""The `embed` stage: vectors for the DFAs of a dfas.parquet or the traces of a traces.parquet.

Output (docs/design.md): Parquet of kind `embeddings` with `id` (a formula_id, or
`formula_id:trace_id`), `kind` (`dfa`, `formula` for the syntax baseline, or `trace`) and
`vector` fixed_size_list<float32>. Embedding is deterministic: the readout takes the expected
random walk, so the same model and input always give the same file.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import pyarrow as pa

from tleaf_cli.data.artifacts import (
    check_writable,
    describe_inputs,
    read_provenance,
    write_artifact,
)
from tleaf_cli.data.dfa_table import read_dfas
from tleaf_cli.data.traces import read_traces
from tleaf_cli.embed.load import load_embedder
from tleaf_cli.errors import InputError, SettingError

KIND = "embeddings"
SCHEMA_VERSION = 1
BATCH = 256


def embed_file(
    model_dir: str | Path,
    source: str | Path,
    out: str | Path,
    dfas: str | Path | None = None,
    on_progress: Callable[[int, int], None] | None = None,
) -> int:
    """Embed every DFA or trace of `source`; returns the number of vectors written."""
    check_writable(out)
    embedder = load_embedder(model_dir)
    kind = read_provenance(source).kind
    if kind == "dfa":
        rows = [r for r in read_dfas(source).rows if r["error"] is None]
        ids = [r["formula_id"] for r in rows]
        matrix = embedder.embed_formula_rows(rows).numpy()
        label = "dfa" if embedder.kind == "dfa" else "formula"
        inputs = [source]
    elif kind == "traces":
        dfas = dfas or _recorded_dfas(source)
        dfa_rows = {r["formula_id"]: r for r in read_dfas(dfas).rows}
        atoms = {f: tuple(r["atoms"]) for f, r in dfa_rows.items()}
        traces = read_traces(source).select(["formula_id", "trace_id", "trace"]).to_pylist()
        missing = {t["formula_id"] for t in traces} - atoms.keys()
        if missing:
            raise InputError(
                f"{dfas}: no formula {sorted(missing)[0]!r} for the traces of {source}"
            )
        ids = [f"{t['formula_id']}:{t['trace_id']}" for t in traces]
        matrix = embedder.embed_traces(
            [t["trace"] for t in traces],
            [atoms[t["formula_id"]] for t in traces],
            [dfa_rows[t["formula_id"]]["alphabet"] == "one-hot" for t in traces],
        ).numpy()
        label = "trace"
        inputs = [source, dfas]
    else:
        raise InputError(f"{source}: a '{kind}' artifact; embed reads dfa or traces artifacts")
    if on_progress:
        on_progress(len(ids), len(ids))
    dim = int(matrix.shape[1])
    table = pa.table(
        {
            "id": pa.array(ids, pa.string()),
            "kind": pa.array([label] * len(ids), pa.string()),
            "vector": pa.FixedSizeListArray.from_arrays(
                pa.array(matrix.astype("float32").ravel(), pa.float32()), dim
            ),
        }
    )
    write_artifact(
        table,
        out,
        kind=KIND,
        schema=SCHEMA_VERSION,
        params={"model": str(Path(model_dir).resolve())},
        inputs=describe_inputs(inputs),
    )
    return len(ids)


def _recorded_dfas(traces_path: str | os.PathLike) -> Path:
    """The dfas.parquet a traces.parquet was made from, as its provenance records it."""
    recorded = read_provenance(traces_path).inputs
    path = Path(recorded[0]["path"]) if recorded else None
    if path is None or not path.exists():
        raise SettingError("dfas", f"needed: {traces_path} records no dfas.parquet that exists")
    return path
