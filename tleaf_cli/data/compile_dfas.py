"""The `compile-dfa` stage: formula sources in, `dfas.parquet` rows out.

Identical formula texts are compiled once; each distinct one is parsed and compiled here or by a
joblib worker, results taken in input order, so `--jobs N` writes the same file as `--jobs 1`.
Formulas go to progression first (logic/compile.py), which takes well under a millisecond for most
and is not cached (a cache lookup costs more); a formula MONA compiles goes through a joblib.Memory
cache keyed on the parsed formula, the alphabet and the versions of everything that shapes the
output, so a formula compiled before costs no MONA call.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache
from importlib import metadata
from pathlib import Path

from joblib import Memory
from ltlf2dfa.ltlf import LTLfFormula

from tleaf_cli.data.artifacts import check_targets, describe_inputs, write_artifact
from tleaf_cli.data.dfa_table import KIND, SCHEMA_VERSION, dfa_payload, make_row, rows_to_table
from tleaf_cli.data.formula_files import FormulaSource, read_formulas
from tleaf_cli.data.parallel import parallel_map
from tleaf_cli.errors import InputError, TleafError
from tleaf_cli.logic import alphabet as alphabet_mod
from tleaf_cli.logic import compile as compile_mod
from tleaf_cli.logic import dfa as dfa_mod
from tleaf_cli.logic import grammar as grammar_mod
from tleaf_cli.logic import guards as guards_mod
from tleaf_cli.logic import mona as mona_mod
from tleaf_cli.logic import progression as progression_mod
from tleaf_cli.logic.alphabet import Alphabet, AlphabetKind, LetterError
from tleaf_cli.logic.compile import Engine, by_mona, by_progression
from tleaf_cli.logic.formulas import FormulaSyntaxError, atoms, parse
from tleaf_cli.logic.mona import MonaError, mona_binary, mona_version
from tleaf_cli.logic.progression import TooLarge
from tleaf_cli.settings.data import CompileSettings
from tleaf_cli.version import __version__


@dataclass
class CompileReport:
    """What a compile run did: the rows, and figures for its summary line."""

    rows: list[dict]
    failures: list[tuple[str, str]]  # (input path, located message) for stderr, input order
    unique: int = 0
    cache_hits: int = 0
    seconds: float = 0.0

    @property
    def compiled(self) -> int:
        return sum(r["error"] is None for r in self.rows)


def compile_sources(
    sources: Sequence[FormulaSource],
    settings: CompileSettings,
    on_progress: Callable[[int, int], None] | None = None,
) -> CompileReport:
    """Compile formulas to rows (input order). `on_progress(done, total)` after each formula."""
    start = time.perf_counter()
    versions = _versions()
    rows: list[dict | None] = [None] * len(sources)
    tasks: dict[str, list[int]] = {}  # formula text (spaces normalised) -> rows waiting for it
    for i, src in enumerate(sources):
        if src.problem is not None:
            rows[i] = make_row(src.formula_id, src.text, None, src.located(src.problem))
        else:
            tasks.setdefault(" ".join(src.text.split()), []).append(i)

    texts = list(tasks)
    # Absolute, so workers started elsewhere (a cluster's) find the same folder.
    cache_dir = str(Path(settings.cache_dir).absolute()) if settings.cache_dir else None
    args = [
        (text, settings.alphabet, settings.timeout, settings.engine, cache_dir, versions)
        for text in texts
    ]
    jobs = 1 if len(texts) < 2 else settings.jobs
    # Most formulas compile in well under a millisecond, faster than workers start: this process
    # compiles too from the first moment (share_work), and a cluster takes them in batches.
    batch = max(1, len(texts) // (4 * max(1, jobs)))
    results = parallel_map(
        _compile_task, args, jobs, settings.cluster, share_work=True, batch_size=batch
    )
    hits = 0
    for k, outcome in enumerate(results):
        hits += outcome.cache_hit
        for i in tasks[texts[k]]:
            src = sources[i]
            error = None if outcome.error is None else src.located(outcome.error, outcome.column)
            rows[i] = make_row(src.formula_id, src.text, outcome.payload, error)
        if on_progress:
            on_progress(k + 1, len(texts))

    failures = [
        (src.path, row["error"])
        for src, row in zip(sources, rows, strict=True)
        if row is not None and row["error"] is not None
    ]
    return CompileReport(
        rows=[r for r in rows if r is not None],
        failures=failures,
        unique=len(texts),
        cache_hits=hits,
        seconds=time.perf_counter() - start,
    )


def compile_file(
    source: str | Path,
    out: str | Path,
    settings: CompileSettings,
    graphs_dir: str | Path | None = None,
    on_progress: Callable[[int, int], None] | None = None,
    sources: list[FormulaSource] | None = None,
    inputs: list[str | Path] | None = None,
) -> CompileReport:
    """Read, compile, write `dfas.parquet` (and graph files); TleafError if the call is unusable.
    `sources`: the formulas of `source` read already (a `.decl`, by knowledge/rule_files.py);
    `inputs`: the files they were read from, for the provenance (`source` alone without).
    A formula with MP-Declare conditions is refused under the one-hot alphabet: a condition
    holds at an event together with its activity, two atoms at once."""
    try:
        mona_binary()  # fail before anything is written when MONA is missing
    except MonaError as e:
        raise TleafError(str(e)) from None
    check_targets(inputs or [source], files=[out], folders=[graphs_dir])
    if sources is None:
        sources = read_formulas(source)
    conditional = [s for s in sources if s.conditions]
    if conditional and settings.alphabet == "one-hot":
        first = conditional[0]
        raise InputError(
            f"{first.path}: {first.location}: rule {first.formula_id} has an MP-Declare "
            f"condition ({len(conditional)} rules have): a condition is true at an event together "
            "with its activity, which the one-hot alphabet (one atom per step) cannot express; "
            "compile it over the powerset alphabet"
        )
    if graphs_dir is not None:
        from tleaf_cli.data.graphs import graph_file_stems  # networkx: only when asked for

        graph_file_stems([src.formula_id for src in sources])  # names that meet: refused now
    report = compile_sources(sources, settings, on_progress)
    if not sources:
        report.failures.append((str(source), "no formulas (empty file, or only comments)"))
    params = {"alphabet": settings.alphabet, "timeout": settings.timeout}
    write_artifact(
        rows_to_table(report.rows),
        out,
        kind=KIND,
        schema=SCHEMA_VERSION,
        params=params,
        inputs=describe_inputs(inputs or [source]),
    )
    if graphs_dir is not None:
        from tleaf_cli.data.graphs import write_graph_files  # networkx: only when asked for

        write_graph_files(report.rows, graphs_dir)
    return report


@dataclass(frozen=True)
class _Outcome:
    payload: dict | None
    error: str | None = None
    column: int | None = None  # of a syntax error, within the formula text
    cache_hit: bool = False


def _compile_task(
    text: str,
    alphabet: AlphabetKind,
    timeout: float,
    engine: Engine,
    cache_dir: str | None,
    versions: tuple[str, ...],
) -> _Outcome:
    """Parse and compile one formula; runs in a worker. The cache is keyed on the parsed form."""
    try:
        formula = parse(text)
        Alphabet(atoms(formula), alphabet)
    except FormulaSyntaxError as e:
        return _Outcome(None, e.message, e.column)
    except LetterError as e:
        return _Outcome(None, str(e))
    try:
        dfa = by_progression(formula, alphabet, engine)
        if dfa is not None:  # quicker than a cache lookup: not cached
            return _Outcome(dfa_payload(dfa))
        canonical = str(formula)
        if cache_dir is None:
            return _Outcome(_compile_payload(canonical, alphabet, timeout, versions, formula))
        cached = _memorized(cache_dir)
        hit = cached.check_call_in_cache(canonical, alphabet, timeout, versions)
        payload = cached(canonical, alphabet, timeout, versions, formula)
        return _Outcome(payload, cache_hit=hit)
    except (MonaError, TooLarge) as e:
        return _Outcome(None, str(e))


def _compile_payload(
    canonical: str,
    alphabet: AlphabetKind,
    timeout: float,
    versions: tuple[str, ...],
    formula: LTLfFormula | None = None,
) -> dict:
    """The cached unit, MONA's DFA keyed on (canonical text, alphabet, versions); `formula` is the
    parse of `canonical`, passed so it is not parsed twice, and left out of the key like
    `timeout`."""
    return dfa_payload(by_mona(formula or parse(canonical), alphabet, timeout))


@cache
def _memorized(cache_dir: str):
    memory = Memory(location=cache_dir, verbose=0)
    return memory.cache(_compile_payload, ignore=["timeout", "formula"])


@cache
def _versions() -> tuple[str, ...]:
    """Everything that shapes a compiled DFA: tool versions and tleaf's logic code."""
    code = hashlib.sha256()
    modules = (
        alphabet_mod,
        compile_mod,
        dfa_mod,
        grammar_mod,
        guards_mod,
        mona_mod,
        progression_mod,
    )
    for module in modules:
        code.update(Path(module.__file__).read_bytes())
    try:
        mona = mona_version()
    except (MonaError, OSError):
        raise TleafError(f"mona not usable; {mona_mod.INSTALL_HINT}") from None
    return (__version__, metadata.version("ltlf2dfa"), mona, code.hexdigest()[:16])
