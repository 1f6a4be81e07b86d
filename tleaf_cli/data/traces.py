"""`traces.parquet` and the `gen-traces` stage: satisfying and violating traces per DFA.

For each formula, K pairs: a satisfying trace drawn uniformly among the accepted words of a
length L, and a violating trace of the same L, so length never gives the label away. Violating
traces are a mix of uniform rejected words and hard negatives (a satisfying trace with as few
steps changed as possible until it is rejected). Each formula draws from its own random stream,
seeded by (seed, formula position), so `--jobs N` writes the same file as `--jobs 1`.
With `once_each`, traces instead read each of the formula's atoms exactly once
(`logic.sampling.once_each_words`), for rule sets of labelled videos.
A formula every trace satisfies (`true`) has no violating trace, so no pairs: it is skipped and
counted (`TraceReport.always_true`), not reported as short.
With `protocol="paper"`, traces are the authors' Table I traces instead (`paper_traces`).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from tleaf_cli.data.artifacts import (
    check_writable,
    describe_inputs,
    read_artifact,
    write_artifact,
)
from tleaf_cli.data.dfa_table import dfa_from_row, read_dfas
from tleaf_cli.data.paper_protocol import (
    accepting_paths,
    paper_negative_words,
    paper_positive_words,
)
from tleaf_cli.data.parallel import parallel_map
from tleaf_cli.logic.checker import PackedDFAs
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.sampling import WordSampler, once_each_words, one_hot_letters
from tleaf_cli.settings.data import TraceSettings

KIND = "traces"
SCHEMA_VERSION = 1
SPLITS = ("train", "val", "test")

COLUMNS = [
    ("formula_id", pa.string()),
    ("trace_id", pa.int32()),
    ("trace", pa.list_(pa.list_(pa.string()))),
    ("label", pa.bool_()),
    ("source", pa.string()),  # "uniform" (sampled), or "hard" (a satisfying trace, edited)
]


@dataclass
class FormulaTraces:
    """One formula's traces (letter-index words) and, when short of K, why."""

    words: list[np.ndarray]
    labels: list[bool]
    sources: list[str]
    shortfall: str | None = None


@dataclass
class TraceReport:
    rows: int
    formulas: int
    skipped: int  # rows of dfas.parquet without a DFA
    short: list[tuple[str, str]]  # (formula_id, reason)
    hard: int
    # formulas every trace satisfies (`true`: kb-extract's rule set of the videos no rule
    # applies to): no trace violates them, so they have no pairs; skipped, not failed
    always_true: list[str] = field(default_factory=list)


ALWAYS_TRUE = "always true: every trace satisfies it, so no trace violates it"


def traces_for_dfa(dfa: DFA, settings: TraceSettings, rng: np.random.Generator) -> FormulaTraces:
    """K satisfying and K violating traces paired by length; fewer, with a reason, if impossible."""
    if settings.once_each:
        return once_each_traces(dfa, settings, rng)
    if settings.protocol == "paper":
        return paper_traces(dfa, rng, settings.paper_arcs, settings.paper_hard)
    letters = one_hot_letters(dfa) if settings.one_hot else None
    sampler = WordSampler(dfa, settings.max_len, letters)
    acc, rej = sampler.counts(True), sampler.counts(False)
    lengths = np.arange(settings.min_len, settings.max_len + 1)
    capacity = np.minimum(acc[lengths], rej[lengths])
    span = f"lengths {settings.min_len}..{settings.max_len}"
    if capacity.sum() == 0:
        kind = "satisfying" if acc[lengths].sum() == 0 else "violating"
        return FormulaTraces([], [], [], f"no {kind} trace at {span}")

    # Lengths of the K pairs: uniform among lengths with room for one more pair on both sides.
    need = np.zeros(len(lengths), dtype=np.int64)
    for _ in range(settings.per_formula):
        open_ = np.flatnonzero(capacity > need)
        if len(open_) == 0:
            break
        need[rng.choice(open_)] += 1

    pairs: list[tuple[np.ndarray, np.ndarray, str]] = []
    for k in np.flatnonzero(need):
        length, m = int(lengths[k]), int(need[k])
        sats = _distinct(sampler, rng, length, True, m, exclude=set())
        taken: set[bytes] = set()
        negs: list[tuple[np.ndarray, str]] = []
        for word in sats:
            if rng.random() < settings.hard_fraction:
                hard = sampler.nearest_rejected(rng, word)
                if hard.tobytes() not in taken:
                    taken.add(hard.tobytes())
                    negs.append((hard, "hard"))
                    continue
            negs.append((None, "uniform"))
        uniform = _distinct(
            sampler, rng, length, False, sum(s == "uniform" for _, s in negs), taken
        )
        fill = iter(uniform)
        for sat, (neg, source) in zip(sats, negs, strict=True):
            neg = next(fill, None) if neg is None else neg
            if neg is not None:
                pairs.append((sat, neg, source))

    words, labels, sources = [], [], []
    for sat, neg, source in pairs:
        words += [sat, neg]
        labels += [True, False]
        sources += ["uniform", source]
    shortfall = None
    if len(pairs) < settings.per_formula:
        shortfall = (
            f"only {len(pairs)} of {settings.per_formula} distinct satisfying/violating pairs "
            f"exist at {span}"
        )
    return FormulaTraces(words, labels, sources, shortfall)


def paper_traces(
    dfa: DFA, rng: np.random.Generator, arcs: str = "guard", hard_fraction: float = 0.0
) -> FormulaTraces:
    """The authors' traces (data/paper_protocol.py): three draws of the letters of up to 10
    simple accepting paths (their arcs `arcs`), each paired with a uniform rejected word of its
    length, or, for a `hard_fraction` share of them, with a hard negative (the rejected word
    with the fewest letters changed) as tleaf's protocol draws them."""
    paths = accepting_paths(dfa, shape=arcs)
    if not paths:
        return FormulaTraces([], [], [], "no accepting path that visits no state twice")
    positives = paper_positive_words(dfa, rng, paths)
    negatives = paper_negative_words(dfa, rng, [len(w) for w in positives])
    hard = WordSampler(dfa, max(len(w) for w in positives)) if hard_fraction > 0 else None
    words, labels, sources = [], [], []
    for sat, neg in zip(positives, negatives, strict=True):
        if neg is None:
            continue
        source = "uniform"
        if hard is not None and rng.random() < hard_fraction:
            neg, source = hard.nearest_rejected(rng, sat), "hard"
        words += [sat, neg]
        labels += [True, False]
        sources += ["uniform", source]
    missing = len(positives) - len(words) // 2
    shortfall = f"{missing} paths' lengths have no rejected word" if missing else None
    return FormulaTraces(words, labels, sources, shortfall)


def once_each_traces(dfa: DFA, settings: TraceSettings, rng: np.random.Generator) -> FormulaTraces:
    """K pairs of traces that read each of the DFA's atoms exactly once, plus up to
    `max_none` "none" steps (the shape of a labelled video under its own rule set)."""
    sats, negs = once_each_words(dfa, rng, settings.per_formula, settings.max_none)
    words, labels, sources = [], [], []
    for sat, (neg, source) in zip(sats, negs, strict=False):
        words += [sat, neg]
        labels += [True, False]
        sources += ["uniform", source]
    shortfall = None
    if len(words) < 2 * settings.per_formula:
        shortfall = (
            f"only {len(words) // 2} of {settings.per_formula} distinct satisfying/violating "
            "pairs found that read each atom once"
        )
    return FormulaTraces(words, labels, sources, shortfall)


def _distinct(sampler, rng, length, accept, m, exclude: set[bytes], rounds: int = 30):
    """Up to m distinct words of one length and label, none in `exclude`."""
    out: list[np.ndarray] = []
    seen = set(exclude)
    for _ in range(rounds):
        if len(out) >= m:
            break
        for word in sampler.sample(rng, length, accept, 2 * (m - len(out)) + 2):
            key = word.tobytes()
            if key not in seen and len(out) < m:
                seen.add(key)
                out.append(word)
    return out


def _formula_job(row: dict, index: int, settings: TraceSettings) -> tuple[list[dict], str | None]:
    """Rows of traces.parquet for one formula (labels verified), and its shortfall if any."""
    dfa = dfa_from_row(row)
    if dfa.accepting[np.unique(dfa.table)].all():  # every state a letter leads to accepts
        return [], ALWAYS_TRUE
    rng = np.random.default_rng([settings.seed, index])
    result = traces_for_dfa(dfa, settings, rng)
    if result.words:
        width = max(len(w) for w in result.words)
        letters = np.zeros((len(result.words), width), dtype=np.int64)
        for i, w in enumerate(result.words):
            letters[i, : len(w)] = w
        lengths = np.array([len(w) for w in result.words])
        checked = PackedDFAs([dfa]).check(np.zeros(len(lengths), dtype=np.int64), letters, lengths)
        if checked.tolist() != result.labels:
            raise AssertionError(f"sampler produced a mislabelled trace for {row['formula_id']}")
    out = [
        {
            "formula_id": row["formula_id"],
            "trace_id": i,
            "trace": [sorted(dfa.alphabet.letter(int(x))) for x in word],
            "label": label,
            "source": source,
        }
        for i, (word, label, source) in enumerate(
            zip(result.words, result.labels, result.sources, strict=True)
        )
    ]
    return out, result.shortfall


def assign_splits(ids: Sequence[str], fractions: tuple[float, float, float], seed: int) -> dict:
    """formula_id -> split, by formula (never one formula in two splits), deterministic."""
    order = np.random.default_rng([seed, 7919]).permutation(len(ids))
    return splits_in_order([ids[i] for i in order], fractions)


def splits_in_order(ids: Sequence[str], fractions: tuple[float, float, float]) -> dict:
    """id -> split: the first `fractions[0]` of `ids` (in the order given) train, then val, test.

    Every split with a positive fraction gets at least one id where there are enough (7 rules
    split 0.8/0.1/0.1 would round val to none, and a q trained on them has no epoch to choose):
    the largest split gives it one."""
    counts = np.diff(np.round(np.cumsum([0.0, *fractions]) * len(ids)).astype(int))
    positive = [i for i, f in enumerate(fractions) if f > 0]
    if len(ids) >= len(positive):
        for i in positive:
            if counts[i] == 0:
                counts[int(np.argmax(counts))] -= 1
                counts[i] = 1
    bounds = np.cumsum(counts)
    return {
        case: SPLITS[int(np.searchsorted(bounds, rank, side="right"))]
        for rank, case in enumerate(ids)
    }


def generate_traces(
    dfas_path: str | os.PathLike,
    out: str | os.PathLike,
    settings: TraceSettings,
    on_progress: Callable[[int, int], None] | None = None,
) -> TraceReport:
    settings.check()
    check_writable(out)
    table = read_dfas(dfas_path)
    compiled = [(i, r) for i, r in enumerate(table.rows) if r["error"] is None]
    args = ((r, i, settings) for i, r in compiled)
    results = parallel_map(_formula_job, args, settings.jobs, settings.cluster, batch_size=8)
    rows: list[dict] = []
    short: list[tuple[str, str]] = []
    always_true: list[str] = []
    for done, ((_, row), (trace_rows, shortfall)) in enumerate(
        zip(compiled, results, strict=True), start=1
    ):
        rows += trace_rows
        if shortfall == ALWAYS_TRUE:
            always_true.append(row["formula_id"])
        elif shortfall:
            short.append((row["formula_id"], shortfall))
        if on_progress:
            on_progress(done, len(compiled))

    columns = list(COLUMNS)
    if settings.split is not None:
        split_of = assign_splits(
            [r["formula_id"] for _, r in compiled], settings.split, settings.seed
        )
        for r in rows:
            r["split"] = split_of[r["formula_id"]]
        columns.append(("split", pa.string()))
    params = {k: v for k, v in settings.__dict__.items() if k not in ("jobs", "cluster")}
    params["data"] = "synthetic: traces sampled from the DFAs by tleaf gen-traces"
    write_artifact(
        pa.Table.from_pylist(rows, schema=pa.schema(columns)),
        out,
        kind=KIND,
        schema=SCHEMA_VERSION,
        params=params,
        inputs=describe_inputs([dfas_path]),
    )
    return TraceReport(
        rows=len(rows),
        formulas=len(compiled),
        skipped=len(table.rows) - len(compiled),
        short=short,
        hard=sum(r["source"] == "hard" for r in rows),
        always_true=always_true,
    )


def read_traces(path: str | os.PathLike) -> pa.Table:
    table, _ = read_artifact(path, KIND, SCHEMA_VERSION)
    return table
