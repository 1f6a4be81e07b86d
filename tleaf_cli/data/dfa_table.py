"""`dfas.parquet`: one row per input formula, the DFA as states and guarded edges.

The format is described in docs/design.md.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import pyarrow as pa

from tleaf_cli.data.artifacts import Provenance, read_artifact
from tleaf_cli.errors import InputError
from tleaf_cli.logic.alphabet import Alphabet
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.guards import row_guards

KIND = "dfa"
SCHEMA_VERSION = 1

EDGE = pa.struct(
    [
        ("src", pa.int32()),
        ("dst", pa.int32()),
        ("guard", pa.string()),
        ("cnf", pa.list_(pa.list_(pa.int32()))),
    ]
)
SCHEMA = pa.schema(
    [
        ("formula_id", pa.string()),
        ("formula", pa.string()),
        ("atoms", pa.list_(pa.string())),
        ("alphabet", pa.string()),
        ("num_states", pa.int32()),
        ("initial", pa.int32()),
        ("accepting", pa.list_(pa.int32())),
        ("edges", pa.list_(EDGE)),
        ("error", pa.string()),
    ]
)


def dfa_payload(dfa: DFA) -> dict[str, Any]:
    """The DFA columns of a row (everything but formula_id, formula and error)."""
    return {
        "atoms": list(dfa.atoms),
        "alphabet": dfa.alphabet.kind,
        "num_states": dfa.num_states,
        "initial": dfa.initial,
        "accepting": [int(s) for s in dfa.accepting.nonzero()[0]],
        "edges": [
            {"src": src, "dst": dst, "guard": guard.text, "cnf": guard.cnf}
            for src in range(dfa.num_states)
            for dst, guard in row_guards(dfa.table[src], dfa.alphabet)
        ],
    }


def make_row(formula_id: str, formula: str, payload: dict | None, error: str | None) -> dict:
    empty = dict.fromkeys(("atoms", "alphabet", "num_states", "initial", "accepting", "edges"))
    return {"formula_id": formula_id, "formula": formula, **(payload or empty), "error": error}


def rows_to_table(rows: Sequence[dict]) -> pa.Table:
    return pa.Table.from_pylist(list(rows), schema=SCHEMA)


def dfa_from_row(row: dict) -> DFA:
    """Rebuild the DFA of a compiled row (checks completeness and determinism)."""
    if row.get("error") is not None:
        raise InputError(f"formula {row['formula_id']} has no DFA: {row['error']}")
    alphabet = Alphabet(tuple(row["atoms"]), row["alphabet"])
    edges = [(e["src"], e["dst"], e["cnf"]) for e in row["edges"]]
    return DFA.from_guards(alphabet, row["num_states"], row["initial"], row["accepting"], edges)


@dataclass
class DfaTable:
    """A loaded `dfas.parquet`: rows in input order, and where they came from."""

    rows: list[dict]
    provenance: Provenance
    path: str

    def ids(self) -> list[str]:
        return [r["formula_id"] for r in self.rows]

    def row(self, formula_id: str) -> dict:
        for r in self.rows:
            if r["formula_id"] == formula_id:
                return r
        raise InputError(f"{self.path}: no formula with id '{formula_id}'")

    def dfa(self, formula_id: str) -> DFA:
        row = self.row(formula_id)
        if row["error"] is not None:
            raise InputError(f"{self.path}: formula '{formula_id}' did not compile: {row['error']}")
        return dfa_from_row(row)

    def compiled(self) -> Iterator[tuple[dict, DFA]]:
        """(row, DFA) for every row that compiled."""
        for r in self.rows:
            if r["error"] is None:
                yield r, dfa_from_row(r)


def read_dfas(path: str | os.PathLike) -> DfaTable:
    table, prov = read_artifact(path, KIND, SCHEMA_VERSION)
    missing = set(SCHEMA.names) - set(table.column_names)
    if missing:
        raise InputError(f"{path}: dfa table lacks columns {sorted(missing)}")
    return DfaTable(table.to_pylist(), prov, str(path))
