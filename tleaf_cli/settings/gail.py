"""Settings of GAIL on Creative Cooking (`tleaf train-task cooking`): fields and presets.
`GailSettings()` is preset `best`, the setting behind every documented result
(docs/results/cooking.md, pipelines/cooking.mk): PPO's learning rate falling linearly to 0 over
the budget, λ 0.01 for the logic losses. `GailSettings.preset("paper")` is the 2021 paper's λ 1
at a constant learning rate (the paper gives no PPO settings; constant is SB3's). Pure Python:
the command line builds the command's options from this module."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

from tleaf_cli.errors import SettingError
from tleaf_cli.settings import DEVICES, LOGIC_LOSSES, Presets, check_values, setting

# PPO learning-rate schedules: constant, or linear from `lr` at the first update to 0 at the last
LR_SCHEDULES = ("constant", "linear")
PAPER_LAMBDA = 1.0  # the paper's λ for GAIL (Sec. VII); also a logic loss's when lam is None


@dataclass(frozen=True)
class GailSettings(Presets):
    """Everything a run depends on (written to config.json).

    The field defaults are preset `best`; `GailSettings.preset("paper")` is the paper's. `lam`
    None (from Python only) lets the run choose: with tleaf the λ q's folder recommends,
    otherwise `PAPER_LAMBDA`."""

    logic_loss: str = setting(
        "none", "none (plain GAIL), tleaf, exact, or checker (no gradient).", choices=LOGIC_LOSSES
    )
    lam: float | None = setting(0.01, "Weight λ of the logic loss.", min=0.0)
    shield: bool = setting(
        False,
        "Act only among the actions the knowledge base's rules still allow (MaskablePPO; the "
        "rules, not the environment's feasibility); without a logic loss.",
    )
    total_steps: int = setting(150_000, "Environment steps to train.", min=1)
    n_envs: int = setting(4, "Environments per rollout.", min=1)
    # PPO: 10 epochs of minibatches of 64 over 4 x 256 steps, no entropy bonus -- 160 gradient
    # steps per rollout where SB3's 4 x 128 / 128 / 4 epochs gave 16 (docs/cooking.md)
    n_steps: int = setting(256, "Steps per environment per rollout.", min=8)
    batch_size: int = 64
    n_epochs: int = 10
    target_kl: float | None = None  # SB3's: stop an update's epochs past 1.5 · target_kl
    clip_range_vf: float | None = None  # SB3's: clip the value's change (None: unclipped)
    lr: float = setting(1e-3, "PPO's learning rate.")
    lr_schedule: str = setting(
        "linear",
        "PPO's learning rate: constant, or linear from --lr down to 0.",
        choices=LR_SCHEDULES,
    )
    gamma: float = 0.99
    ent_coef: float = 0.0
    hidden: int = 64  # policy and value MLPs (two layers)
    disc_hidden: int = 64
    disc_lr: float = 1e-3
    disc_steps: int = 4  # discriminator steps per rollout
    disc_batch: int = 256  # expert and policy pairs per discriminator step
    disc_gp: float = 1.0  # zero-centred gradient penalty on D's logit (discriminator.py)
    reward: str = "log_d"  # log_d: log D(s, a); logit: log D − log(1 − D) (discriminator.py)
    bc_steps: int = 0  # behaviour-cloning Adam steps on the demos before GAIL (0: none)
    bc_lr: float = 1e-3
    logic_episodes: int = 4  # rollout episodes in each minibatch's logic term
    eval_every: int = setting(4096, "Environment steps between evaluations.", min=1)
    eval_episodes: int = setting(8, "Seeded episodes per evaluation (true reward).", min=1)
    held_out: int = setting(
        8,
        "Also evaluate, one episode each, on this many ingredient sets no demo shows (a fixed, "
        "seeded pool); 0: none.",
        min=0,
    )
    seed: int = setting(0, "Random seed; the same seed trains the same policy.")
    device: str = setting("cpu", "Where to compute.", choices=DEVICES)
    threads: int = 1  # torch CPU threads
    domain: Path | None = setting(
        None, "Domain TOML.", auto="the Creative Cooking domain in examples/"
    )

    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "best": {},
        "paper": {"lam": PAPER_LAMBDA, "lr_schedule": "constant"},
    }
    PRESET_HELP: ClassVar[dict[str, str]] = {
        "best": "every documented result's: λ 0.01 (at 1 and 0.1 the logic losses stop GAIL "
        "learning), PPO's learning rate falling linearly to 0 over the budget",
        "paper": "the 2021 paper's λ 1, PPO at a constant learning rate (the paper gives no PPO "
        "settings; constant is SB3's)",
    }

    def check(self) -> None:
        """SettingError for a setting out of range or settings that do not fit together."""
        check_values(self)
        if self.shield and self.logic_loss != "none":
            raise SettingError("shield", "runs without a logic loss for now (logic_loss none)")
