"""The Creative Cooking task: train-task cooking (GAIL) and eval cooking."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import (
    CacheDir,
    NoCache,
    Quiet,
    cache_folder,
    exits,
    given_flags,
    preset_option,
    refuse,
    targets,
)
from tleaf_cli.cli.options import GAIL, given, with_settings
from tleaf_cli.settings.data import CompileSettings
from tleaf_cli.settings.gail import GailSettings

GailPreset = preset_option(GailSettings)
DEFAULT_GAIL_PRESET = GailSettings.default_preset()


@exits
@with_settings(GAIL)
def train_task_cooking(
    ctx: typer.Context,
    demos: Annotated[Path, typer.Argument(help="Expert demonstrations (gen-demos).")],
    embedder: Annotated[
        Path | None, typer.Option(help="q: a train-meta directory (needed for --logic-loss tleaf).")
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Run directory to write.")] = Path("run"),
    preset: GailPreset = DEFAULT_GAIL_PRESET,
    cache_dir: CacheDir = None,
    no_cache: NoCache = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """GAIL (PPO + discriminator) imitating the demos, with λ·ℓ_logic on the policy.

    Writes config.json, metrics.json (true-reward return vs environment steps on the demonstrated
    and the held-out ingredient sets, the expert's and a uniform policy's return on each),
    policy.zip (SB3) and discriminator.pt; metrics.json also holds the λ used and where it came
    from, printed before the first update. Settings beyond plain GAIL, for every variant alike:
    a gradient penalty on the discriminator and 10 PPO epochs of minibatches of 64 per rollout
    (docs/cooking.md).
    """
    from tleaf_cli.tasks.cooking.train import train_gail

    settings = GailSettings.preset(preset, **given(ctx, values))
    lam_given = given_flags(ctx, "lam")
    if settings.logic_loss == "none":
        refuse(lam_given, "only with a logic loss, not --logic-loss none")
    logic_loss = settings.logic_loss
    targets([demos, embedder, settings.domain], folders=[out])
    compiling = CompileSettings(alphabet="one-hot", cache_dir=cache_folder(cache_dir, no_cache))
    how = "given with --lambda" if lam_given else f"the {preset} preset's"
    with ui.progress(f"GAIL ({logic_loss})", quiet) as update:
        m = train_gail(
            demos,
            out,
            settings,
            embedder,
            compiling,
            update,
            on_setup=lambda setup: ui.summary(setup.lam.text(given=how), quiet),
        )
    ui.summary(
        f"{out}: return {m['curve'][0]['mean_return']:.2f} -> {m['final_return']:.2f} after "
        f"{m['environment_steps']} steps (expert {m['expert_return']:.2f}, uniform policy "
        f"{m['random_return']:.2f}; {m['seconds']:.0f} s)",
        quiet,
    )


@exits
def eval_cooking(
    runs: Annotated[list[Path], typer.Argument(help="train-task cooking run directories.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path("report"),
    quiet: Quiet = False,
) -> None:
    """Return vs environment steps per variant (mean ± s.e. over seeds), like the paper's Fig. 5B.

    Writes report.png, report.json and report.md (steps to reach 90 % of the expert's return).
    """
    from tleaf_cli.tasks.cooking.gail_report import evaluate_cooking_runs

    targets(runs, [out / f"report.{ext}" for ext in ("json", "md", "png")], [out])
    report = evaluate_cooking_runs(runs, out)
    reached = ", ".join(
        f"{name} {v['steps_to_90'] if v['steps_to_90'] is not None else 'not reached'}"
        for name, v in report["variants"].items()
    )
    ui.summary(f"{out}/report.md: {len(runs)} runs; steps to 90% of expert: {reached}", quiet)
