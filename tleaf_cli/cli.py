"""The `tleaf` command line: one thin function per stage; the work is in the library.

Exit status (docs/design.md): 0 all good; 1 some inputs failed (the rest was written, each failure
recorded with its reason); 2 the call itself is unusable.
"""

from __future__ import annotations

import functools
import gc
from pathlib import Path
from typing import Annotated, Literal

import typer

from tleaf_cli import __version__, ui
from tleaf_cli.cli_options import SettingsCommand, flag, given, with_settings
from tleaf_cli.defaults import CANDIDATE_TIMEOUT, COMPILE_TIMEOUT, MAX_LEN, MIN_LEN, TIERS
from tleaf_cli.errors import InputError, SettingError, TleafError
from tleaf_cli.settings import DEVICES, PRECISIONS
from tleaf_cli.settings.action_recognition import DECODINGS, RULE_SET_SPLITS, TaskSettings
from tleaf_cli.settings.edge import EdgeSettings
from tleaf_cli.settings.gail import GailSettings
from tleaf_cli.settings.meta import MetaSettings

# The library is imported inside each command, so `tleaf --help` and light commands start fast
# (ltlf2dfa alone pulls in sympy).


def _shown_params(params: list) -> list:
    """`params` as --help and usage lines should show them: every on/off flag with an empty
    metavar (typer's help would show a flag as taking a `<bool>` value, which it does not), and
    every positional argument named in upper case, `FORMULAS` (typer writes its name as it is,
    and `{formulas}` in usage lines); `REPORTS...` for one that takes several."""
    for param in params:
        if getattr(param, "is_flag", False) and param.metavar is None:
            param.metavar = ""
        elif isinstance(param, typer.core.TyperArgument) and param.metavar is None:
            param.metavar = param.name.upper() + ("..." if param.nargs != 1 else "")
    return params


def _usage_pieces(command: typer.core.TyperCommand | typer.core.TyperGroup, ctx) -> list[str]:
    """The usage line after the command's name, as click writes it: `[OPTIONS] FORMULAS`, an
    optional argument in brackets (typer wraps a required one in braces, `{formulas}`)."""
    pieces = [command.options_metavar] if command.options_metavar else []
    for param in command.get_params(ctx):
        if isinstance(param, typer.core.TyperArgument):
            pieces.append(param.metavar if param.required else f"[{param.metavar}]")
        else:
            pieces.extend(param.get_usage_pieces(ctx))
    return pieces


def _plain_errors(parse_args):
    """`parse_args` whose refusal of a value reads as click's own: typer checks a `Literal`'s
    values through pydantic, whose message for the ValueError it raises starts with "Value
    error, " ("Invalid value for '--tier': Value error, 'extreme' is not one of ...")."""

    @functools.wraps(parse_args)
    def wrapper(self, ctx, args):
        try:
            return parse_args(self, ctx, args)
        except typer.BadParameter as e:  # typer's own click, not the click package
            e.message = e.message.removeprefix("Value error, ")
            raise

    return wrapper


class Command(typer.core.TyperCommand):
    """A tleaf command: its flags show no type in --help, its arguments upper-case names, its
    refusals of a value no pydantic prefix."""

    def get_params(self, ctx) -> list:
        return _shown_params(super().get_params(ctx))

    def collect_usage_pieces(self, ctx) -> list[str]:
        return _usage_pieces(self, ctx)

    parse_args = _plain_errors(typer.core.TyperCommand.parse_args)


class Group(typer.core.TyperGroup):
    """tleaf and its sub-apps (eval, train-task): their flags show no type in --help, their
    refusals of a value no pydantic prefix."""

    def get_params(self, ctx) -> list:
        return _shown_params(super().get_params(ctx))

    def collect_usage_pieces(self, ctx) -> list[str]:
        return [*_usage_pieces(self, ctx), self.subcommand_metavar]

    parse_args = _plain_errors(typer.core.TyperGroup.parse_args)


app = typer.Typer(
    name="tleaf",
    cls=Group,
    help="T-LEAF toolchain: LTLf rules -> DFAs -> embeddings -> logic losses.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)

Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar or summary.")]
Jobs = Annotated[int, typer.Option("--jobs", "-j", min=1, help="Parallel worker processes.")]
Cluster = Annotated[
    str | None,
    typer.Option(
        envvar="TLEAF_CLUSTER",
        metavar="ADDRESS",
        help="Run the parallel work on this dask.distributed scheduler (tcp://host:8786; "
        "needs tleaf\\[cluster]) instead of local processes; --jobs is then unused.",
    ),
]
Seed = Annotated[int, typer.Option(help="Random seed; the same seed writes the same file.")]
MinLen = Annotated[int, typer.Option(min=1, help="Shortest trace length.")]
MaxLen = Annotated[int, typer.Option(min=1, help="Longest trace length.")]
CacheDir = Annotated[
    Path | None,
    typer.Option(help="Compile cache \\[default: $TLEAF_CACHE_DIR or ~/.cache/tleaf]."),
]
NoCache = Annotated[bool, typer.Option("--no-cache", help="Neither read nor fill the cache.")]
# The training commands' options come from their settings dataclasses (tleaf_cli/settings/).
EDGE = SettingsCommand(EdgeSettings, "train-edge")
META = SettingsCommand(MetaSettings, "train-meta")
TASK = SettingsCommand(TaskSettings, "train-task action-recognition")
GAIL = SettingsCommand(GailSettings, "train-task cooking")
SETTINGS_COMMANDS = [EDGE, META, TASK, GAIL]
MetaPreset = Literal[tuple(MetaSettings.PRESETS)]
DEFAULT_META_PRESET = MetaSettings.default_preset()
# Options with a fixed set of values are typed with them, so --help lists them and a value
# outside them is refused before any work; tests/test_cli_help.py checks each against the
# library's tuple of the same values (TIERS, READOUTS, ...).
Tier = Literal["low", "moderate", "high"]
KbFormulaFrom = Literal["labels"]
RuleSets = Literal[RULE_SET_SPLITS]
PairFeatures = Literal["concat", "rich"]
EvalDevice = Literal[DEVICES]
Precision = Literal[PRECISIONS]
CompileEngine = Literal["auto", "progression", "mona"]  # logic/compile.py ENGINES
Engine = Annotated[
    CompileEngine,
    typer.Option(
        help="auto: build the DFA in this process by formula progression, and hand a "
        "formula to MONA when that passes its limits (2,000 states); progression: never "
        "MONA (such formulas fail); mona: MONA for every formula. All give the same "
        "minimal DFA."
    ),
]
Decoding = Literal[DECODINGS]  # test-time decoding of train-task action-recognition

Resume = Annotated[
    bool, typer.Option("--resume", help="Continue from the model directory's last epoch.")
]


def _compile_settings(
    one_hot: bool,
    timeout: float,
    cache_dir,
    no_cache: bool,
    jobs: int,
    cluster: str | None = None,
    engine: CompileEngine = "auto",
):
    from tleaf_cli.data.compile_dfas import CompileSettings, default_cache_dir

    return CompileSettings(
        alphabet="one-hot" if one_hot else "powerset",
        timeout=timeout,
        cache_dir=None if no_cache else (cache_dir or default_cache_dir()),
        jobs=jobs,
        engine=engine,
        cluster=cluster or None,
    )


def _exits(func):
    """Turn a TleafError into one stderr line and its exit status, never a traceback; a
    SettingError is told by the flag that sets it."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except SettingError as e:
            ui.fatal(f"{flag(e.setting)}: {e.args[0]}")
            raise typer.Exit(e.exit_code) from None
        except TleafError as e:
            ui.fatal(str(e))
            raise typer.Exit(e.exit_code) from None
        except OSError as e:  # the environment, not tleaf: a full disk, a vanished folder
            ui.fatal(f"{e.filename or ''}: {e.strerror or e}".lstrip(": "))
            raise typer.Exit(2) from None
        except KeyboardInterrupt:
            ui.fatal("interrupted; nothing was written")
            raise typer.Exit(130) from None

    return wrapper


def _targets(inputs, files=(), folders=()) -> None:
    """Refuse the call (exit 2, nothing written) when an output cannot be written or would
    overwrite an input or another output; called first thing, before any work."""
    from tleaf_cli.data.artifacts import check_targets

    check_targets(inputs, files, folders)


def _reachable(cluster: str | None) -> None:
    """Refuse the call (exit 2, nothing written) when --cluster names no scheduler that answers."""
    from tleaf_cli.data.parallel import check_cluster

    check_cluster(cluster)


def _given(ctx: typer.Context, *names: str) -> list[str]:
    """The flags among `names` (parameter names) given on the command line, not defaulted."""
    sources = [ctx.get_parameter_source(name) for name in names]
    return [
        flag(name)
        for name, source in zip(names, sources, strict=True)
        if source is not None and source.name in ("COMMANDLINE", "PROMPT")
    ]


def _refuse(given: list[str], reason: str) -> None:
    """InputError when options that would be ignored were given: `reason` says why."""
    if given:
        raise InputError(f"{', '.join(given)}: {reason}")


def _finish(failures: list[tuple[str, str]], summary: str, quiet: bool) -> None:
    """One stderr line per failure, the summary line, and exit status 1 if anything failed."""
    ui.failures(failures)
    ui.summary(summary, quiet)
    if failures:
        raise typer.Exit(1)


def _epoch_printer(update, epochs: int, scored_on: str, quiet: bool):
    """A training callback: advance the bar and print one line per epoch."""

    def on_epoch(r) -> None:
        update(r.epoch, epochs)
        ui.summary(
            f"epoch {r.epoch}: loss {r.loss:.4f}, train acc {r.train_accuracy:.3f}, "
            f"{scored_on} acc {r.heldout_accuracy:.3f} ({r.seconds:.0f} s)",
            quiet,
        )

    return on_epoch


def _version(value: bool) -> None:
    if value:
        ui.text(f"tleaf {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print version.")
    ] = False,
) -> None:
    """T-LEAF toolchain: LTLf rules -> DFAs -> embeddings -> logic losses."""


@app.command("compile-dfa", cls=Command)
@_exits
def compile_dfa(
    formulas: Annotated[
        Path, typer.Argument(help="A .ltl file, or Parquet with formula_id, formula.")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="The dfas.parquet to write.")] = Path(
        "dfas.parquet"
    ),
    one_hot: Annotated[
        bool,
        typer.Option(
            "--one-hot",
            help="One atom of the domain per step: letters are single atoms or none; "
            "DFAs minimal over that alphabet, guards simplified under it.",
        ),
    ] = False,
    jobs: Jobs = 1,
    cluster: Cluster = None,
    timeout: Annotated[
        float, typer.Option(min=0.1, help="Seconds MONA may spend on one formula.")
    ] = COMPILE_TIMEOUT,
    engine: Engine = "auto",
    graphs: Annotated[
        Path | None, typer.Option(help="Also write <id>.graphml and <id>.dot per DFA here.")
    ] = None,
    cache_dir: Annotated[
        Path | None,
        typer.Option(help="Compile cache \\[default: $TLEAF_CACHE_DIR or ~/.cache/tleaf]."),
    ] = None,
    no_cache: Annotated[
        bool, typer.Option("--no-cache", help="Neither read nor fill the cache.")
    ] = False,
    quiet: Quiet = False,
) -> None:
    """Compile LTLf formulas to minimal DFAs, one row per formula.

    A formula that fails (syntax, timeout) gets a row whose `error` says why; the others are still
    compiled, and the exit status is 1.
    """
    from tleaf_cli.data.compile_dfas import compile_file

    settings = _compile_settings(one_hot, timeout, cache_dir, no_cache, jobs, cluster, engine)
    _reachable(cluster)
    with ui.progress("compiling", quiet) as update:
        report = compile_file(formulas, out, settings, graphs, update)
    _finish(
        report.failures,
        f"{out}: {report.compiled} of {len(report.rows)} formulas compiled "
        f"({report.unique} distinct, {report.cache_hits} from cache, "
        f"{len(report.rows) - report.compiled} failed) in {report.seconds:.2f} s",
        quiet,
    )


@app.command("gen-formulas", cls=Command)
@_exits
def gen_formulas(
    ctx: typer.Context,
    out: Annotated[Path, typer.Option("--out", "-o", help="The .ltl file to write.")] = Path(
        "formulas.ltl"
    ),
    tier: Annotated[
        Tier | None,
        typer.Option(
            help="The paper's settings: low (3 atoms, size 10), moderate (3, 20), "
            "high (6, 20). Overrides --atoms and --size."
        ),
    ] = None,
    atoms: Annotated[int, typer.Option(help="Distinct atoms in every formula (a, b, c, ...).")] = 3,
    size: Annotated[
        int, typer.Option(help="Syntax-tree nodes (operators + atom occurrences).")
    ] = 10,
    n: Annotated[int, typer.Option("-n", min=1, help="Formulas to keep.")] = 100,
    seed: Seed = 0,
    min_len: MinLen = MIN_LEN,
    max_len: MaxLen = MAX_LEN,
    pairs: Annotated[
        int,
        typer.Option(
            min=1,
            help="Keep formulas with at least this many distinct "
            "(satisfying, violating) pairs of equal length: gen-traces' --per-formula.",
        ),
    ] = 20,
    one_hot: Annotated[
        bool, typer.Option("--one-hot", help="Judge formulas on one-hot traces.")
    ] = False,
    prefix: Annotated[
        str | None, typer.Option(help="Formula id prefix \\[default: the tier, or f].")
    ] = None,
    jobs: Jobs = 1,
    cluster: Cluster = None,
    timeout: Annotated[
        float, typer.Option(min=0.001, help="MONA seconds per candidate; slower ones are rejected.")
    ] = CANDIDATE_TIMEOUT,
    cache_dir: CacheDir = None,
    no_cache: NoCache = False,
    quiet: Quiet = False,
) -> None:
    """Draw SYNTHETIC random LTLf formulas worth learning from.

    Rejects unsatisfiable and valid formulas, formulas with fewer than --pairs distinct
    (satisfying, violating) pairs of equal length in [--min-len, --max-len], repeats of a
    language already kept, and candidates MONA cannot finish within --timeout.
    """
    from tleaf_cli.data.formula_gen import FormulaSettings, generate_formulas, write_formula_file

    _targets([], [out])
    _reachable(cluster)
    if tier is not None:
        _refuse(_given(ctx, "atoms", "size"), "set by --tier; give --tier or these, not both")
        if tier not in TIERS:
            raise SettingError("tier", f"must be one of {', '.join(TIERS)}, not '{tier}'")
        atoms, size = TIERS[tier]
    settings = FormulaSettings(
        n=n,
        atoms=atoms,
        size=size,
        seed=seed,
        min_len=min_len,
        max_len=max_len,
        pairs=pairs,
        one_hot=one_hot,
        prefix=prefix or (f"{tier}-" if tier else "f"),
        compile=_compile_settings(one_hot, timeout, cache_dir, no_cache, jobs, cluster),
    )
    with ui.progress("generating", quiet) as update:
        report = generate_formulas(settings, update)
    write_formula_file(report, settings, out)
    reasons = ", ".join(f"{k}: {v}" for k, v in report.rejected.most_common()) or "none"
    ui.summary(
        f"{out}: kept {len(report.kept)} of {report.drawn} drawn "
        f"({atoms} atoms, size {size}); rejected {sum(report.rejected.values())} ({reasons})",
        quiet,
    )
    if len(report.kept) < n:
        ui.fatal(f"only {len(report.kept)} of {n} formulas found before the draw limit")
        raise typer.Exit(1)


def _fractions(text: str | None) -> tuple[float, float, float] | None:
    if text is None:
        return None
    try:
        parts = tuple(float(x) for x in text.split(","))
    except ValueError:
        parts = ()
    if len(parts) != 3:
        raise SettingError("split", f"takes three fractions like 0.8,0.1,0.1, not '{text}'")
    return parts  # type: ignore[return-value]


@app.command("gen-traces", cls=Command)
@_exits
def gen_traces(
    ctx: typer.Context,
    dfas: Annotated[Path, typer.Argument(help="A dfas.parquet from compile-dfa.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="The traces.parquet to write.")] = Path(
        "traces.parquet"
    ),
    per_formula: Annotated[
        int, typer.Option(min=1, help="K: satisfying and K violating traces per formula.")
    ] = 20,
    min_len: MinLen = MIN_LEN,
    max_len: MaxLen = MAX_LEN,
    hard_fraction: Annotated[
        float, typer.Option(help="Share of violating traces that are hard negatives.")
    ] = 0.5,
    one_hot: Annotated[
        bool, typer.Option("--one-hot", help="One-hot letters only (a single atom, or none).")
    ] = False,
    once_each: Annotated[
        bool,
        typer.Option(
            "--once-each",
            help="Traces that read every atom of the formula exactly once (plus 0..--max-none "
            "'none' steps), like a labelled video under its own rule set; implies --one-hot "
            "letters; ignores --min-len, --max-len, --hard-fraction.",
        ),
    ] = False,
    max_none: Annotated[
        int,
        typer.Option(
            min=0,
            help="With --once-each: at most this many 'none' steps (other pairs of the video; "
            "more for per-ingredient rule sets).",
        ),
    ] = 3,
    split: Annotated[
        str | None, typer.Option(help="Add a split column by formula: train,val,test fractions.")
    ] = None,
    seed: Seed = 0,
    jobs: Jobs = 1,
    cluster: Cluster = None,
    quiet: Quiet = False,
) -> None:
    """Sample SYNTHETIC satisfying and violating traces for every DFA, paired by length.

    Satisfying traces are uniform among accepted words of a length; violating ones are uniform
    rejected words or hard negatives (a satisfying trace with the fewest steps changed). Every
    label is checked with the exact checker. Exit 1 if some DFA cannot give K of each.
    """
    from tleaf_cli.data.traces import TraceSettings, generate_traces

    _targets([dfas], [out])
    _reachable(cluster)
    if once_each:
        ignored = _given(ctx, "min_len", "max_len", "hard_fraction")
        _refuse(ignored, "ignored with --once-each (a video's length is set by its atoms)")
    else:
        _refuse(_given(ctx, "max_none"), "only with --once-each")
    settings = TraceSettings(
        per_formula=per_formula,
        min_len=min_len,
        max_len=max_len,
        hard_fraction=hard_fraction,
        one_hot=one_hot or once_each,
        once_each=once_each,
        max_none=max_none,
        seed=seed,
        split=_fractions(split),
        jobs=jobs,
        cluster=cluster or None,
    )
    with ui.progress("sampling", quiet) as update:
        report = generate_traces(dfas, out, settings, update)
    skipped = f", {report.skipped} rows without a DFA skipped" if report.skipped else ""
    _finish(
        [(str(dfas), f"formula {fid}: {why}") for fid, why in report.short],
        f"{out}: {report.rows} traces for {report.formulas} formulas "
        f"({report.hard} hard negatives; {len(report.short)} formulas short of {per_formula} "
        f"pairs{skipped})",
        quiet,
    )


@app.command("gen-activities", cls=Command)
@_exits
def gen_activities(
    out: Annotated[
        Path, typer.Option("--out", "-o", help="The activities.parquet to write.")
    ] = Path("activities.parquet"),
    kb_out: Annotated[
        Path, typer.Option(help="Where to write the knowledge base that generated the data.")
    ] = Path("kb.ltl"),
    actions: Annotated[int, typer.Option(help="Actions (at most the paper's 64).")] = 16,
    ingredients: Annotated[int, typer.Option(help="Ingredients (at most the paper's 155).")] = 24,
    feature_dim: Annotated[
        int, typer.Option(help="Feature size per step (2048 like ResNet).")
    ] = 128,
    noise: Annotated[float, typer.Option(help="Std of the per-step Gaussian noise.")] = 1.0,
    confusable: Annotated[
        float, typer.Option(help="0..1: how far paired classes' means are pulled together.")
    ] = 0.5,
    ingredient_scale: Annotated[
        float,
        typer.Option(help="Ingredient means' norm relative to actions' (>1: easier to see)."),
    ] = 1.5,
    train: Annotated[int, typer.Option(help="Training videos.")] = 60,
    val: Annotated[int, typer.Option(help="Validation videos.")] = 40,
    test: Annotated[int, typer.Option(help="Test videos.")] = 200,
    unlabelled: Annotated[
        int,
        typer.Option(help="Unlabelled videos (split 'unlabelled'; only logic losses use them)."),
    ] = 0,
    min_steps: Annotated[int, typer.Option(help="Fewest steps in a video.")] = 5,
    max_steps: Annotated[int, typer.Option(help="Most steps in a video.")] = 15,
    seed: Seed = 0,
    quiet: Quiet = False,
) -> None:
    """Generate SYNTHETIC procedural activity videos and the knowledge base they satisfy.

    A hidden process (affordances, recipe-stage orderings) yields labelled (action, ingredient)
    steps; features are class-conditional Gaussians with confusable class pairs.
    """
    from tleaf_cli.tasks.action_recognition.activity_gen import (
        ActivitySettings,
        generate_activities,
    )

    _targets([], [out, kb_out])
    settings = ActivitySettings(
        actions=actions,
        ingredients=ingredients,
        feature_dim=feature_dim,
        noise=noise,
        confusable=confusable,
        ingredient_scale=ingredient_scale,
        train=train,
        val=val,
        test=test,
        unlabelled=unlabelled,
        min_steps=min_steps,
        max_steps=max_steps,
        seed=seed,
    )
    with ui.progress("generating videos", quiet) as update:
        report = generate_activities(settings, out, kb_out, update)
    ui.summary(
        f"{out}: {report.videos} synthetic videos ({train} train, {val} val, {test} test, "
        f"{unlabelled} unlabelled), "
        f"{report.rows} steps; {kb_out}: {report.affordances} affordances, "
        f"{report.orderings} orderings ({report.seconds:.1f} s)",
        quiet,
    )


@app.command("kb-extract", cls=Command)
@_exits
def kb_extract(
    inputs: Annotated[
        list[Path],
        typer.Argument(
            metavar="[KB.ltl] ACTIVITIES.parquet",
            help="A knowledge base (optional with --mine), then the labelled activities.",
        ),
    ],
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Folder for samples.parquet and dfas.parquet.")
    ] = Path("kb"),
    formula_from: Annotated[
        KbFormulaFrom, typer.Option(help="Which pairs give a video its rules: labels.")
    ] = "labels",
    rule_sets: Annotated[
        RuleSets,
        typer.Option(
            help="video: one rule set per video; ingredient: one per (video, ingredient), the "
            "formulas of a q for train-task --rule-sets ingredient."
        ),
    ] = "video",
    mine: Annotated[
        bool,
        typer.Option("--mine", help="Mine rules from the train split (written to OUT/kb.ltl)."),
    ] = False,
    min_support: Annotated[
        int, typer.Option(min=1, help="Train videos that must show an ordering to mine it.")
    ] = 3,
    jobs: Jobs = 1,
    cluster: Cluster = None,
    timeout: Annotated[
        float, typer.Option(min=0.1, help="Seconds MONA may spend on one rule set.")
    ] = COMPILE_TIMEOUT,
    engine: Engine = "auto",
    cache_dir: CacheDir = None,
    no_cache: NoCache = False,
    quiet: Quiet = False,
) -> None:
    """Give every video the conjunction of the rules whose atoms all occur in it; compile each
    distinct rule set once (one-hot DFAs).

    Writes OUT/samples.parquet (video -> rule set) and OUT/dfas.parquet (one row per rule set).
    """
    from tleaf_cli.tasks.action_recognition.kb_extract import extract_knowledge

    if not 1 <= len(inputs) <= 2:
        raise InputError("give [KB.ltl] ACTIVITIES.parquet: one or two files")
    kb = inputs[0] if len(inputs) == 2 else None
    written = ["samples.parquet", "dfas.parquet"] + (["kb.ltl"] if mine else [])
    _targets(inputs, [out / name for name in written], [out])
    _reachable(cluster)
    if kb is None and not mine:
        raise InputError("give a knowledge base file, or --mine to mine one from the train split")
    settings = _compile_settings(True, timeout, cache_dir, no_cache, jobs, cluster, engine)
    with ui.progress("compiling rule sets", quiet) as update:
        report = extract_knowledge(
            kb, inputs[-1], out, settings, mine, min_support, formula_from, rule_sets, update
        )
    mined = f"; {report.mined} rules mined" if report.mined is not None else ""
    _finish(
        report.failures,
        f"{out}: {report.videos} videos, {report.rule_sets} distinct rule sets "
        f"({report.compiled} compiled, {report.cache_hits} from cache); {report.rules_used} of "
        f"{report.rules_total} rules apply to some video{mined} ({report.seconds:.1f} s)",
        quiet,
    )


@app.command("train-edge", cls=Command)
@_exits
@with_settings(EDGE)
def train_edge(
    dfas: Annotated[Path, typer.Argument(help="A dfas.parquet: its guards are the training data.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Model directory to write.")] = Path(
        "edge_model"
    ),
    resume: Resume = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """Train the edge embedder q_e: guards close to letters that satisfy them (triplet loss).

    Held-out triplet accuracy (d(guard, sat) < d(guard, unsat)) on formulas never trained on is
    reported each epoch; the best epoch's weights are kept.
    """
    from tleaf_cli.embed.train_edge import train_edge as run

    _targets([dfas], folders=[out])
    settings = EdgeSettings(**values)
    with ui.progress("training q_e (epochs)", quiet) as update:
        on_epoch = _epoch_printer(update, settings.epochs, "held-out", quiet)
        metrics = run(dfas, out, settings, resume=resume, on_epoch=on_epoch)
    best = metrics["best"]
    ui.summary(
        f"{out}: best held-out triplet accuracy {best['heldout_accuracy']:.3f} "
        f"(epoch {best['epoch']} of {len(metrics['history'])})",
        quiet,
    )


@app.command("train-meta", cls=Command)
@_exits
@with_settings(META)
def train_meta(
    ctx: typer.Context,
    dfas: Annotated[Path, typer.Argument(help="The dfas.parquet the traces were drawn from.")],
    traces: Annotated[Path, typer.Argument(help="A traces.parquet with a split column.")],
    edge: Annotated[Path, typer.Option(help="The edge model directory from train-edge.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Model directory to write.")] = Path(
        "meta_model"
    ),
    preset: Annotated[
        MetaPreset,
        typer.Option(
            help="Settings to start from; options given on the command line override them. "
            + "; ".join(f"{name}: {text}" for name, text in MetaSettings.PRESET_HELP.items())
            + "."
        ),
    ] = DEFAULT_META_PRESET,
    resume: Resume = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """Train the meta embedder q_m (or the syntax-tree baseline) with the triplet loss.

    Triplets (formula, satisfying trace, violating trace) from the train split; the best epoch on
    the val split is kept; the test split (formulas never trained on) gives the final figures.
    The model folder's config.json records every setting and the tleaf loss's λ that fits q.
    """
    from tleaf_cli.embed.train_meta import train_meta as run

    _targets([dfas, traces, edge], folders=[out])
    chosen = given(ctx, values)
    settings = MetaSettings.preset(preset, **chosen)
    if settings.readout not in ("accept", "runs"):
        _refuse(
            [flag(n) for n in ("bins", "probes") if n in chosen],
            "only with --readout accept or runs",
        )
    if settings.readout not in ("walk", "steps"):
        _refuse([flag(n) for n in ("steps",) if n in chosen], "only with --readout walk or steps")
    if settings.monitors == 0:
        _refuse(
            [flag(n) for n in ("monitor_ranges", "evidence") if n in chosen and values[n]],
            "only with --monitors",
        )
    if settings.evidence is False:
        _refuse([flag(n) for n in ("evidence_scale",) if n in chosen], "only with --evidence")
    with ui.progress(f"training q ({settings.embedder})", quiet) as update:
        on_epoch = _epoch_printer(update, settings.epochs, "val", quiet)
        metrics = run(dfas, traces, edge, out, settings, resume=resume, on_epoch=on_epoch)
    test = metrics["test"]
    ui.summary(
        f"{out}: test triplet accuracy {test['triplet_accuracy']:.3f} "
        f"(uniform negatives {test['uniform_negatives']:.3f}, hard {test['hard_negatives']:.3f}; "
        f"best val epoch {metrics['best']['epoch']})",
        quiet,
    )


@app.command("embed", cls=Command)
@_exits
def embed(
    model: Annotated[Path, typer.Argument(help="A meta model directory from train-meta.")],
    source: Annotated[Path, typer.Argument(help="A dfas.parquet or a traces.parquet.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="The vectors.parquet to write.")] = Path(
        "vectors.parquet"
    ),
    dfas: Annotated[
        Path | None,
        typer.Option(
            help="For traces: their dfas.parquet \\[default: the one their file records]."
        ),
    ] = None,
    quiet: Quiet = False,
) -> None:
    """Vectors for every DFA or trace (deterministic for a model and an input)."""
    from tleaf_cli.embed.vectors import embed_file

    _targets([model, source, dfas], [out])
    with ui.progress("embedding", quiet) as update:
        count = embed_file(model, source, out, dfas, update)
    ui.summary(f"{out}: {count} vectors", quiet)


@app.command("gen-demos", cls=Command)
@_exits
def gen_demos(
    out: Annotated[Path, typer.Option("--out", "-o", help="The demos.parquet to write.")] = Path(
        "demos.parquet"
    ),
    episodes: Annotated[int, typer.Option(min=1, help="Expert episodes to record.")] = 32,
    domain: Annotated[
        Path | None,
        typer.Option(help="Domain TOML \\[default: examples/creative_cooking.toml]."),
    ] = None,
    seed: Seed = 0,
    quiet: Quiet = False,
) -> None:
    """Record expert demonstrations in the SYNTHETIC Creative Cooking environment.

    The expert plans each episode optimally (A* over the environment's exact rules) and its plan
    is played in tleaf/CreativeCooking-v0; one row per step. Success rate and mean return go to
    the artifact's params and the summary line.
    """
    from tleaf_cli.tasks.cooking.demos import DemoSettings, generate_demos
    from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN

    _targets([domain], [out])
    settings = DemoSettings(episodes=episodes, seed=seed, domain=domain or DEFAULT_DOMAIN)
    with ui.progress("planning and playing", quiet) as update:
        report = generate_demos(out, settings, update)
    ui.summary(
        f"{out}: {report.episodes} synthetic expert episodes, {report.rows} steps; success rate "
        f"{100 * report.success_rate:.1f}%, mean return {report.mean_return:.2f}, mean length "
        f"{report.mean_length:.2f} (planning {report.planning_seconds:.2f} s)",
        quiet,
    )


@app.command("cooking-kb", cls=Command)
@_exits
def cooking_kb(
    out: Annotated[Path, typer.Option("--out", "-o", help="The .ltl file to write.")] = Path(
        "cooking_kb.ltl"
    ),
    ingredients: Annotated[
        str | None,
        typer.Option(help="Comma-separated ingredients (an episode's five) \\[default: all]."),
    ] = None,
    mixture: Annotated[
        bool, typer.Option("--mixture/--no-mixture", help="Include rules on the mixture's actions.")
    ] = True,
    domain: Annotated[
        Path | None,
        typer.Option(help="Domain TOML \\[default: examples/creative_cooking.toml]."),
    ] = None,
    quiet: Quiet = False,
) -> None:
    """Write Creative Cooking's rules as LTLf (affordance.* and ordering.* formulas).

    Atoms are the environment's action names (cut_lettuce); compile with `compile-dfa --one-hot`.
    """
    from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN
    from tleaf_cli.tasks.cooking.knowledge import write_cooking_kb

    _targets([domain], [out])
    names = [n.strip() for n in ingredients.split(",")] if ingredients else None
    rules = write_cooking_kb(out, domain or DEFAULT_DOMAIN, names, mixture)
    orderings = sum(r.kind == "ordering" for r in rules)
    ui.summary(
        f"{out}: {len(rules)} rules ({len(rules) - orderings} affordance, {orderings} ordering) "
        f"over {len(names) if names else 'all'} ingredients",
        quiet,
    )


eval_app = typer.Typer(
    cls=Group, help="Evaluate embedders and trained models.", no_args_is_help=True
)
app.add_typer(eval_app, name="eval")


@eval_app.command("model-checking", cls=Command)
@_exits
def eval_model_checking(
    dfas: Annotated[Path, typer.Argument(help="The dfas.parquet of the formulas.")],
    traces: Annotated[Path, typer.Argument(help="A traces.parquet with a split column.")],
    embedder: Annotated[Path, typer.Option(help="A meta model directory (train-meta).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path("report"),
    pair_features: Annotated[
        PairFeatures, typer.Option(help="concat (the paper's) or rich (adds |a-b| and a*b).")
    ] = "concat",
    label: Annotated[str, typer.Option(help="A name for the report (e.g. the tier).")] = "",
    all_negatives: Annotated[
        bool,
        typer.Option(
            help="Also fit a second MLP on all negatives, hard ones too (doubles the time)."
        ),
    ] = False,
    device: Annotated[
        EvalDevice, typer.Option(help="Where q embeds and the MLPs train: cpu or cuda.")
    ] = "cpu",
    precision: Annotated[
        Precision,
        typer.Option(
            help="float32; bfloat16: the MLPs' products under autocast, 3-4x faster on CPUs "
            "with AMX / AVX-512 BF16 (slower on others); auto: bfloat16 where the hardware "
            "computes it natively, else float32."
        ),
    ] = "float32",
    seed: Seed = 0,
    quiet: Quiet = False,
) -> None:
    """Predict from (z_formula, z_trace) alone whether the trace satisfies the formula.

    An MLP (512, 128) and the distance rule d < tau are fitted on the train split, chosen on val,
    and scored on the test split (formulas never trained on). Writes report.json and report.md.
    """
    from tleaf_cli.tasks.model_checking import EvalSettings, evaluate_model_checking

    _targets([dfas, traces, embedder], [out / "report.json", out / "report.md"], [out])
    settings = EvalSettings(
        pair_features=pair_features,
        seed=seed,
        label=label,
        all_negatives=all_negatives,
        device=device,
        precision=precision,
    )
    with ui.progress("evaluating", quiet):
        report = evaluate_model_checking(embedder, dfas, traces, out, settings)
    ui.summary(
        f"{out}/report.json: MLP {100 * report['mlp']['accuracy']:.2f}%, distance rule "
        f"{100 * report['distance']['accuracy']:.2f}% on {report['test_formulas']} test formulas",
        quiet,
    )


@eval_app.command("tsne", cls=Command)
@_exits
def eval_tsne(
    dfas: Annotated[Path, typer.Argument(help="The dfas.parquet of the formulas.")],
    traces: Annotated[Path, typer.Argument(help="The traces.parquet (its split picks a formula).")],
    embedder: Annotated[
        list[Path], typer.Option(help="A meta model directory; repeat for side-by-side panels.")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="The PNG to write.")] = Path("tsne.png"),
    formula: Annotated[
        str | None, typer.Option(help="Formula id \\[default: the test formula with most traces].")
    ] = None,
    pairs: Annotated[int, typer.Option(min=2, help="Satisfying/violating pairs to draw.")] = 150,
    seed: Seed = 0,
    quiet: Quiet = False,
) -> None:
    """The paper's Fig. 3: a test formula and its traces, embedded, projected with t-SNE."""
    from tleaf_cli.tasks.model_checking_figure import FigureSettings, tsne_figure

    _targets([dfas, traces, *embedder], [out])
    settings = FigureSettings(formula_id=formula, pairs=pairs, seed=seed)
    with ui.progress("t-SNE", quiet):
        shown = tsne_figure(embedder, dfas, traces, out, settings)
    nearer = ", ".join(
        f"{e['kind']} {e['sat_nearer_than_violating']:.2f}" for e in shown["embedders"]
    )
    ui.summary(
        f"{out}: formula {shown['formula_id']}, {sum(shown['points'].values())} traces; "
        f"satisfying nearer than violating: {nearer}",
        quiet,
    )


@eval_app.command("table", cls=Command)
@_exits
def eval_table(
    reports: Annotated[list[Path], typer.Argument(help="report.json files of model-checking.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="The markdown table.")] = Path(
        "results.md"
    ),
) -> None:
    """One table: mean ± s.e. over seeds per embedder and tier, beside the paper's Table I."""
    from tleaf_cli.tasks.model_checking_table import results_table

    _targets(reports, [out])
    ui.text(results_table(reports, out).rstrip())


train_task_app = typer.Typer(
    cls=Group,
    help="Train a target model h with a logic loss (the paper's downstream tasks).",
    no_args_is_help=True,
)
app.add_typer(train_task_app, name="train-task")


@train_task_app.command("action-recognition", cls=Command)
@_exits
@with_settings(TASK)
def train_task_action_recognition(
    ctx: typer.Context,
    activities: Annotated[Path, typer.Argument(help="An activities.parquet (gen-activities).")],
    kb: Annotated[Path, typer.Option(help="The knowledge base (.ltl) the rule sets come from.")],
    embedder: Annotated[
        Path | None, typer.Option(help="q: a train-meta directory (needed for --logic-loss tleaf).")
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Run directory to write.")] = Path("run"),
    resume: Resume = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """Train the action recognizer h with ℓ_task + λ·ℓ_logic; best val action accuracy is kept.

    Writes config.json, weights.pt and metrics.json (per epoch: task and logic loss, seconds,
    val action accuracy; test: action / ingredient / pair accuracy, violation fraction, and with
    --decode constrained the same under constrained decoding, with its time per video).
    """
    from tleaf_cli.tasks.action_recognition.train import train_action_recognition

    _targets([activities, kb, embedder], folders=[out])
    settings = TaskSettings(**values)
    if settings.decode != "constrained":
        _refuse(_given(ctx, "decode_top_k"), "only with --decode constrained")
    model, logic_loss, epochs = settings.model, settings.logic_loss, settings.epochs
    with ui.progress(f"training h ({model}, {logic_loss})", quiet) as update:

        def on_epoch(r) -> None:
            update(r.epoch, epochs)
            ui.summary(
                f"epoch {r.epoch}: task {r.task_loss:.4f}, logic {r.logic_loss:.4f}, "
                + (f"unlabelled {r.unlabelled_loss:.4f}, " if r.unlabelled_loss else "")
                + f"val action acc {r.val_action_accuracy:.3f} ({r.seconds:.1f} s)",
                quiet,
            )

        metrics = train_action_recognition(
            activities, kb, embedder, out, settings, on_epoch, resume=resume
        )
    test = metrics["test"]
    ui.summary(
        f"{out}: test action {100 * test['action_accuracy']:.2f}%, ingredient "
        f"{100 * test['ingredient_accuracy']:.2f}%, pair {100 * test['pair_accuracy']:.2f}%, "
        f"violating {100 * test['violation_fraction']:.1f}% of videos (best epoch "
        f"{metrics['best']['epoch']}, {metrics['mean_epoch_seconds']:.2f} s/epoch)",
        quiet,
    )
    if "constrained" in test:
        c = test["constrained"]
        ui.summary(
            f"constrained decoding: test action {100 * c['action_accuracy']:.2f}%, violating "
            f"{100 * c['violation_fraction']:.1f}% of videos, "
            f"{1000 * c['decode_seconds_per_video']:.1f} ms/video",
            quiet,
        )


@eval_app.command("action-recognition", cls=Command)
@_exits
def eval_action_recognition(
    runs: Annotated[list[Path], typer.Argument(help="train-task action-recognition run dirs.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path("report"),
    decode: Annotated[
        Decoding,
        typer.Option(
            help="Whose test figures fill the main table: argmax, or constrained decoding "
            "(runs trained with --decode constrained). Runs that have both also get a table "
            "of the two side by side."
        ),
    ] = "argmax",
    quiet: Quiet = False,
) -> None:
    """Accuracy and violations per run; relative change against the same-seed reference run.

    Writes report.json, report.md and report.png (boxplots like the paper's Fig. 4B).
    """
    from tleaf_cli.tasks.action_recognition.evaluate import evaluate_runs

    _targets(runs, [out / f"report.{ext}" for ext in ("json", "md", "png")], [out])
    report = evaluate_runs(runs, out, decode)
    ui.summary(
        f"{out}/report.md: {len(report['runs'])} runs, {len(report['pairs'])} compared with "
        "their reference",
        quiet,
    )


@eval_app.command("learning-curve", cls=Command)
@_exits
def eval_learning_curve(
    runs: Annotated[
        list[Path],
        typer.Argument(
            help="train-task action-recognition run dirs (--train-videos, --decode "
            "constrained), every size, with the reference (--logic-loss none)."
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path("curve"),
    sweep: Annotated[
        list[Path] | None,
        typer.Option(
            help="A run of the λ sweep (repeat): each model, loss and size's λ choice "
            "on val is shown."
        ),
    ] = None,
    quiet: Quiet = False,
) -> None:
    """Action accuracy against training videos per variant (loss x decoding): the gain over the
    same-seed reference, and the training videos the reference needs to match each variant.

    Writes curve.md, curve.json and curve.png (accuracy vs videos, log scale, mean ± s.e.).
    """
    from tleaf_cli.tasks.action_recognition.learning_curve import learning_curve

    sweep = sweep or []
    _targets([*runs, *sweep], [out / f"curve.{ext}" for ext in ("json", "md", "png")], [out])
    result = learning_curve(runs, out, sweep)
    ui.summary(
        f"{out}/curve.md: {len(result['runs'])} runs, {len(result['curve'])} (model, size, "
        f"variant) cells, {len(result['lambda_choices'])} λ choices",
        quiet,
    )


@eval_app.command("choose-lambda", cls=Command)
@_exits
def eval_choose_lambda(
    runs: Annotated[
        list[Path],
        typer.Argument(
            help="train-task action-recognition run dirs of one model, loss and "
            "size that differ only in λ and seed."
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Text file for the chosen λ.")] = Path(
        "lambda.txt"
    ),
    quiet: Quiet = False,
) -> None:
    """The λ with the best mean val action accuracy (best epoch) over the runs' seeds; ties go
    to the smaller λ. Writes it to a text file, as %g prints it."""
    from tleaf_cli.tasks.action_recognition.learning_curve import choose_lambda_file

    _targets(runs, [out])
    choice = choose_lambda_file(runs, out)
    table = ", ".join(
        f"{v['lambda']:g}: {100 * v['val_action_accuracy']:.2f}%" for v in choice["val"]
    )
    ui.summary(f"{out}: λ {choice['lambda']:g} (mean val action accuracy {table})", quiet)


@eval_app.command("violations", cls=Command)
@_exits
def eval_violations(
    runs: Annotated[list[Path], typer.Argument(help="train-task action-recognition run dirs.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path("violations"),
    split: Annotated[
        list[str] | None,
        typer.Option(
            metavar="<train|val|test>",
            help="A split to read (repeat) \\[default: train and test]; train: the first "
            "train_videos videos of the train split, those the run trained on.",
        ),
    ] = None,
    quiet: Quiet = False,
) -> None:
    """Which rules each run's argmax outputs break, per split: the share of videos breaking an
    affordance rule, an ordering rule, any rule; the share of steps on forbidden pairs and the
    probability given them; P(rules hold) for the video's own rules and the whole knowledge base.

    Writes violations.json and violations.md.
    """
    from tleaf_cli.tasks.action_recognition.violations import DEFAULT_SPLITS, violation_report

    _targets(runs, [out / "violations.json", out / "violations.md"], [out])
    with ui.progress("reading the runs' outputs", quiet):
        report = violation_report(runs, out, split or DEFAULT_SPLITS)
    ui.summary(
        f"{out}/violations.md: {len(runs)} runs, splits {', '.join(report['splits'])}", quiet
    )


@app.command("demos-kb", cls=Command)
@_exits
def demos_kb(
    demos: Annotated[Path, typer.Argument(help="A demos.parquet (gen-demos).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="The .ltl file to write.")] = Path(
        "demos_kb.ltl"
    ),
    domain: Annotated[
        Path | None,
        typer.Option(help="Domain TOML \\[default: examples/creative_cooking.toml]."),
    ] = None,
    quiet: Quiet = False,
) -> None:
    """Write the Creative Cooking rules of the demos' ingredient sets (no mixture rules).

    The training formulas of the embedder q for `train-task cooking --logic-loss tleaf`; compile
    them with `compile-dfa --one-hot`.
    """
    from tleaf_cli.tasks.cooking.demo_episodes import write_demos_knowledge_base
    from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, load_domain

    _targets([demos, domain], [out])

    rules = write_demos_knowledge_base(demos, out, load_domain(domain or DEFAULT_DOMAIN))
    orderings = sum(r.kind == "ordering" for r in rules)
    ui.summary(
        f"{out}: {len(rules)} rules ({len(rules) - orderings} affordance, {orderings} ordering)",
        quiet,
    )


@train_task_app.command("cooking", cls=Command)
@_exits
@with_settings(GAIL)
def train_task_cooking(
    demos: Annotated[Path, typer.Argument(help="Expert demonstrations (gen-demos).")],
    embedder: Annotated[
        Path | None, typer.Option(help="q: a train-meta directory (needed for --logic-loss tleaf).")
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Run directory to write.")] = Path("run"),
    cache_dir: CacheDir = None,
    no_cache: NoCache = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """GAIL (PPO + discriminator) imitating the demos, with λ·ℓ_logic on the policy.

    Writes config.json, metrics.json (true-reward return vs environment steps on the demonstrated
    and the held-out ingredient sets, the expert's and a uniform policy's return on each),
    policy.zip (SB3) and discriminator.pt. Settings beyond plain GAIL, for every variant alike:
    a gradient penalty on the discriminator and 10 PPO epochs of minibatches of 64 per rollout
    (docs/cooking.md).
    """
    from tleaf_cli.tasks.cooking.gail import train_gail

    settings = GailSettings(**values)
    logic_loss = settings.logic_loss
    _targets([demos, embedder, settings.domain], folders=[out])
    compile_settings = _compile_settings(True, COMPILE_TIMEOUT, cache_dir, no_cache, 1)
    with ui.progress(f"GAIL ({logic_loss})", quiet) as update:
        m = train_gail(demos, out, settings, embedder, compile_settings, update)
    ui.summary(
        f"{out}: return {m['curve'][0]['mean_return']:.2f} -> {m['final_return']:.2f} after "
        f"{m['environment_steps']} steps (expert {m['expert_return']:.2f}, uniform policy "
        f"{m['random_return']:.2f}; {m['seconds']:.0f} s)",
        quiet,
    )


@eval_app.command("cooking", cls=Command)
@_exits
def eval_cooking(
    runs: Annotated[list[Path], typer.Argument(help="train-task cooking run directories.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path("report"),
    quiet: Quiet = False,
) -> None:
    """Return vs environment steps per variant (mean ± s.e. over seeds), like the paper's Fig. 5B.

    Writes report.png, report.json and report.md (steps to reach 90 % of the expert's return).
    """
    from tleaf_cli.tasks.cooking.gail_report import evaluate_cooking_runs

    _targets(runs, [out / f"report.{ext}" for ext in ("json", "md", "png")], [out])
    report = evaluate_cooking_runs(runs, out)
    reached = ", ".join(
        f"{name} {v['steps_to_90'] if v['steps_to_90'] is not None else 'not reached'}"
        for name, v in report["variants"].items()
    )
    ui.summary(f"{out}/report.md: {len(runs)} runs; steps to 90% of expert: {reached}", quiet)


@app.command("inspect", cls=Command)
@_exits
def inspect(
    path: Annotated[Path, typer.Argument(help="Any tleaf artifact (.parquet).")],
    formula_id: Annotated[
        str | None, typer.Option("--id", help="Show one DFA of a dfas.parquet.")
    ] = None,
    dot: Annotated[
        bool, typer.Option("--dot", help="With --id: print Graphviz DOT (also with --draw).")
    ] = False,
    draw: Annotated[
        Path | None, typer.Option(help="With --id: draw to .png/.svg/.pdf (Graphviz) or .dot.")
    ] = None,
    rows: Annotated[
        int | None, typer.Option(min=0, help="How many first rows to show. \\[default: 10]")
    ] = None,
    stats: Annotated[
        bool, typer.Option("--stats", help="Distributions: DFA sizes; trace labels and lengths.")
    ] = False,
) -> None:
    """Show an artifact: kind, schema, provenance, row count, first rows; or one DFA with --id."""
    from tleaf_cli import views

    _targets([path], [draw])
    if formula_id is None:
        if dot or draw:
            raise InputError("--dot and --draw need --id (which DFA to draw)")
        if stats:
            _refuse(["--rows"] if rows is not None else [], "not with --stats")
            views.show_stats(path)
        else:
            views.show_artifact(path, 10 if rows is None else rows)
    else:
        _refuse(["--rows"] if rows is not None else [], "not with --id (one DFA is shown)")
        _refuse(["--stats"] if stats else [], "not with --id")
        views.show_dfa(path, formula_id, dot, draw)


# Python's collector runs a full collection whenever the objects that survived two collections
# have grown by a quarter: importing torch and building a run's data (objects that live for the
# whole command) cost about ten full collections, 0.9-1.5 s of each training or evaluation
# command. A young collection every 50,000 allocations instead of 700 leaves none of them;
# garbage with reference cycles is still collected, only later.
GC_THRESHOLDS = (50_000, 20, 20)


def main() -> None:
    gc.set_threshold(*GC_THRESHOLDS)
    app()
