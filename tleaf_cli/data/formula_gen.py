"""The `gen-formulas` stage: random LTLf formulas that are worth learning from.

Candidates of an exact syntax-tree size over an exact number of atoms (`random_formulas.py`) are
compiled in batches (through the compile stage, so `--jobs` and the cache apply) and kept only if
their language is new and has both satisfying and violating traces at some length that
`gen-traces` will use. Rejections are counted by reason.

With `protocol="paper"` the candidates are spot randltl's and the filters the authors' (their
text not drawn before, at most 20 states, at least 5 accepting paths, a rejected word within 40
letters: `paper_protocol.py`); lengths and pairs then play no part.
"""

from __future__ import annotations

import json
import random
import string
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tleaf_cli.data.artifacts import write_text_atomic
from tleaf_cli.data.compile_dfas import compile_sources
from tleaf_cli.data.dfa_table import dfa_from_row
from tleaf_cli.data.formula_files import NAME_CHARS, FormulaSource, check_names, is_valid_name
from tleaf_cli.data.paper_protocol import paper_reason, spot_formula
from tleaf_cli.data.random_formulas import random_formula
from tleaf_cli.errors import SettingError
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.sampling import WordSampler, one_hot_letters
from tleaf_cli.settings.data import CompileSettings, FormulaSettings

REASONS = (
    "unsatisfiable",
    "valid",
    "trivial at the trace lengths",
    "same language as a kept one",
    "did not compile",
)


@dataclass
class FormulaReport:
    kept: list[tuple[str, str]]  # (formula_id, text)
    drawn: int = 0
    rejected: Counter = field(default_factory=Counter)


def judge(dfa: DFA, min_len: int, max_len: int, one_hot: bool, pairs: int = 1) -> str | None:
    """Why a compiled formula teaches nothing, or None if it is worth keeping.

    Kept formulas have at least `pairs` (satisfying, violating) pairs of distinct traces of equal
    length in [min_len, max_len], which is what `gen-traces --per-formula` will ask for.
    """
    letters = one_hot_letters(dfa) if one_hot else None
    first = dfa.table[dfa.initial, letters if letters is not None else slice(None)]
    after_one = _reachable_from(dfa, np.unique(first), letters)
    if not dfa.accepting[after_one].any():
        return "unsatisfiable"
    if dfa.accepting[after_one].all():
        return "valid"
    sampler = WordSampler(dfa, max_len, letters)
    span = slice(min_len, max_len + 1)
    if np.minimum(sampler.counts(True)[span], sampler.counts(False)[span]).sum() < pairs:
        return "too few traces at the trace lengths"
    return None


def _reachable_from(dfa: DFA, start: np.ndarray, letters) -> np.ndarray:
    table = dfa.table if letters is None else dfa.table[:, letters]
    seen = np.zeros(dfa.num_states, dtype=bool)
    seen[start] = True
    frontier = start
    while len(frontier):
        nxt = np.unique(table[frontier])
        frontier = nxt[~seen[nxt]]
        seen[frontier] = True
    return np.flatnonzero(seen)


def generate_formulas(
    settings: FormulaSettings, on_progress: Callable[[int, int], None] | None = None
) -> FormulaReport:
    """Draw, compile and filter until `settings.n` formulas are kept (or the draws run out)."""
    settings.check()
    if settings.prefix and not is_valid_name(settings.prefix):
        raise SettingError(
            "prefix", f"starts formula names: only {NAME_CHARS}, not '{settings.prefix}'"
        )
    rng = random.Random(settings.seed)
    atoms = list(string.ascii_lowercase[: settings.atoms])
    compile_settings = CompileSettings(
        alphabet="one-hot" if settings.one_hot else "powerset",
        timeout=settings.timeout,
        cache_dir=settings.cache_dir,
        jobs=settings.jobs,
        cluster=settings.cluster,
    )
    report = FormulaReport(kept=[])
    languages: set[bytes] = set()
    paper = settings.protocol == "paper"
    drawn_texts: set[str] = set()  # paper: spot's randltl never yields a text twice
    judge_rng = np.random.default_rng([settings.seed, 1])
    max_draws = 50 * settings.n + 1000
    while len(report.kept) < settings.n and report.drawn < max_draws:
        # Draw about what the rejection rate so far says is needed, plus a margin.
        rejected = sum(report.rejected.values())
        rate = min((rejected + 1) / (report.drawn + 10), 0.9)
        missing = settings.n - len(report.kept)
        batch = min(int(missing / (1 - rate) * 1.1) + 16, max_draws - report.drawn)
        if paper:
            texts = []
            for _ in range(batch):
                text = spot_formula(rng, atoms, settings.size)
                if text in drawn_texts:
                    report.drawn += 1
                    report.rejected["same text as an earlier draw"] += 1
                    continue
                drawn_texts.add(text)
                texts.append(text)
        else:
            texts = [random_formula(rng, atoms, settings.size) for _ in range(batch)]
        sources = [
            FormulaSource(f"c{k}", t, "<generated>", f"draw {report.drawn + k}")
            for k, t in enumerate(texts)
        ]
        compiled = compile_sources(sources, compile_settings).rows
        for text, row in zip(texts, compiled, strict=True):
            if len(report.kept) >= settings.n:
                break
            report.drawn += 1
            if row["error"] is not None:
                report.rejected["did not compile"] += 1
                continue
            dfa = dfa_from_row(row)
            if paper:
                reason = paper_reason(dfa, judge_rng, settings.paper_arcs)
                if reason is not None:
                    report.rejected[reason] += 1
                else:
                    report.kept.append((f"{settings.prefix}{len(report.kept):05d}", text))
                continue
            reason = judge(
                dfa, settings.min_len, settings.max_len, settings.one_hot, settings.pairs
            )
            key = dfa.table.tobytes() + dfa.accepting.tobytes() + bytes([dfa.initial])
            if reason is None and key in languages:
                reason = "same language as a kept one"
            if reason is not None:
                report.rejected[reason] += 1
                continue
            languages.add(key)
            report.kept.append((f"{settings.prefix}{len(report.kept):05d}", text))
        if on_progress:
            on_progress(len(report.kept), settings.n)
    return report


def write_formula_file(report: FormulaReport, settings: FormulaSettings, out: str | Path) -> None:
    """The kept formulas as a `.ltl` file whose header comments record how they were made."""
    header = {
        "kind": "synthetic formulas (tleaf gen-formulas)",
        "atoms": settings.atoms,
        "size": settings.size,
        "n": settings.n,
        "seed": settings.seed,
        "min_len": settings.min_len,
        "max_len": settings.max_len,
        "pairs": settings.pairs,
        "one_hot": settings.one_hot,
        "protocol": settings.protocol,
        "paper_arcs": settings.paper_arcs,
        "drawn": report.drawn,
        "kept": len(report.kept),
        "rejected": dict(report.rejected),
    }
    lines = [
        "# Synthetic LTLf formulas generated by `tleaf gen-formulas` (not the paper's data set).",
        f"# {json.dumps(header, sort_keys=True)}",
    ]
    check_names((fid for fid, _ in report.kept), "formula id")
    lines += [f"{fid}: {text}" for fid, text in report.kept]
    write_text_atomic(out, "\n".join(lines) + "\n")
