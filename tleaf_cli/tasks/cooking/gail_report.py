"""`tleaf eval cooking`: return vs environment steps per variant, like the paper's Fig. 5B.

Runs (train-task cooking directories) are grouped by variant (their logic loss, or `shield`).
Per variant and evaluation point: the mean over seeds ± its standard error (std / √n, 0 for one
seed). Curves of one variant must share their evaluation steps (same settings); runs of different
lengths are cut to the shortest. Everything is summarised per evaluation pool: the demonstrated
ingredient sets, and the held-out sets no demo shows (pools.py), each against the expert's and
the uniform policy's return on the same pool; the report opens with one table of both.

Steps to 90 % of the expert: the first evaluation step at which the variant's MEAN curve reaches
0.9 × the expert's mean return (the demos' return on the evaluation episodes' ingredient sets),
and the same per seed. A second, normalised form is reported beside it: the first step at which
(R − R_random) / (R_expert − R_random) ≥ 0.9, R_random the uniform policy's return on the same
seeded episodes. "not reached" is written as null. The tleaf / none ratio of the per-seed
MEDIAN steps to 90 % comes with a 95 % bootstrap interval over seeds (`median_ratio`).

What can be compared when a variant does not reach 90 %: the return at fixed fractions of the
budget (mean ± s.e. over seeds at the first evaluation at or after 25 %, 50 % and 100 % of the
last evaluated step, `at_fraction`), and the steps to a QUARTER and to HALF the way from the
uniform policy to the expert, (R − R_random) / (R_expert − R_random) ≥ 0.25 or 0.5
(`steps_to_quarter`, `steps_to_half`; mean curve and per seed). Beside them, per variant (each
a mean ± s.e. over seeds of a per-run number): the mean return over the whole curve (the area
under it, per step), each run's best evaluation, and from the training log the rule violation
rate of the sampled actions (logged for every variant with a logic term: checker's is plain
GAIL's) and the policy's entropy, over the first and the last `ROLLOUTS` rollouts.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from tleaf_cli.data.artifacts import write_text_atomic
from tleaf_cli.errors import InputError
from tleaf_cli.tasks.figures import pyplot, save_png

ORDER = ("none", "checker", "exact", "tleaf", "shield")
FRACTIONS = (0.25, 0.5, 1.0)  # of the budget, for the return at fixed steps
ROLLOUTS = 10  # first / last rollouts averaged for the violation rate and the entropy
BOOTSTRAP_DRAWS = 10_000  # for the interval of tleaf / none median steps to 90 %


def read_run(run: str | Path) -> dict:
    path = Path(run) / "metrics.json"
    try:
        metrics = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: no such file (not a train-task cooking run)") from None
    except json.JSONDecodeError as e:
        raise InputError(f"{path}: line {e.lineno}: not JSON ({e.msg})") from None
    missing = [k for k in ("variant", "seed", "curve", "expert_return") if k not in metrics]
    if missing:
        raise InputError(f"{path}: missing {', '.join(missing)} (not a train-task cooking run)")
    return metrics


def first_reaching(steps: np.ndarray, values: np.ndarray, threshold: float) -> int | None:
    """The first step whose value is ≥ threshold, or None."""
    hit = np.flatnonzero(values >= threshold)
    return int(steps[hit[0]]) if len(hit) else None


def mean_se(values: list[float | None]) -> dict | None:
    """{"mean", "stderr", "n"} over the values that are not None (None if there are none)."""
    kept = np.array([v for v in values if v is not None], dtype=float)
    if not len(kept):
        return None
    se = kept.std(ddof=1) / np.sqrt(len(kept)) if len(kept) > 1 else 0.0
    return {"mean": float(kept.mean()), "stderr": float(se), "n": len(kept)}


def median_ratio(
    numerator: list[int | None],
    denominator: list[int | None],
    draws: int = BOOTSTRAP_DRAWS,
    seed: int = 0,
) -> dict:
    """median(numerator) / median(denominator) of per-seed steps to a level, with a 95 %
    percentile-bootstrap interval over seeds (each variant's seeds resampled on their own).

    A seed that never reached the level counts as never (∞), so the median is finite only while
    more than half of a variant's seeds got there: finite / ∞ = 0, ∞ / finite = ∞, ∞ / ∞ is
    undefined (such draws are dropped and counted). Returns {"ratio", "low", "high", "draws",
    "undefined_draws", "numerator_median", "denominator_median"}, a value None where it is
    undefined or ∞."""
    a = np.array([np.inf if s is None else s for s in numerator], dtype=float)
    b = np.array([np.inf if s is None else s for s in denominator], dtype=float)

    def ratio(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.median(x, axis=-1) / np.median(y, axis=-1)

    rng = np.random.default_rng(seed)
    boot = ratio(
        a[rng.integers(0, len(a), (draws, len(a)))], b[rng.integers(0, len(b), (draws, len(b)))]
    )
    kept = boot[~np.isnan(boot)]

    def finite(v: float) -> float | None:
        return float(v) if np.isfinite(v) else None

    low = np.quantile(kept, 0.025, method="lower") if len(kept) else np.nan
    high = np.quantile(kept, 0.975, method="higher") if len(kept) else np.nan
    return {
        "ratio": finite(ratio(a, b)),
        "low": finite(low),
        "high": finite(high),
        "draws": draws,
        "undefined_draws": int(draws - len(kept)),
        "numerator_median": finite(np.median(a)),
        "denominator_median": finite(np.median(b)),
    }


def rollout_average(metrics: dict, key: str, last: bool) -> float | None:
    """The mean of `key` over the first (or last) ROLLOUTS rollouts where it was logged."""
    rows = metrics.get("rollouts", [])
    rows = rows[-ROLLOUTS:] if last else rows[:ROLLOUTS]
    values = [r[key] for r in rows if r.get(key) is not None]
    return float(np.mean(values)) if values else None


# Per evaluation pool: the curve's key, and the run's expert and uniform-policy returns on it.
POOLS = {
    "demonstrated": ("mean_return", "expert_return", "random_return"),
    "held_out": ("held_out_mean_return", "expert_return_held_out", "random_return_held_out"),
}


def summarise(runs: list[dict], pool: str = "demonstrated") -> dict:
    """Per variant: the mean ± s.e. curve on `pool` and the steps to 90 % of the expert there
    (runs that did not evaluate on that pool are left out)."""
    curve_key, expert_key, random_key = POOLS[pool]
    variants: dict[str, list[dict]] = {}
    for m in runs:
        if expert_key in m:
            variants.setdefault(m["variant"], []).append(m)
    out = {}
    for name in sorted(variants, key=lambda v: (ORDER.index(v) if v in ORDER else 99, v)):
        group = sorted(variants[name], key=lambda m: m["seed"])
        points = min(len(m["curve"]) for m in group)
        steps = np.array([p["steps"] for p in group[0]["curve"][:points]])
        returns = np.array([[p[curve_key] for p in m["curve"][:points]] for m in group])
        expert = float(np.mean([m[expert_key] for m in group]))
        random = float(np.mean([m.get(random_key, np.nan) for m in group]))
        per_seed_90 = [first_reaching(steps, r, 0.9 * expert) for r in returns]
        reached = [s for s in per_seed_90 if s is not None]
        mean = returns.mean(axis=0)
        se = (
            returns.std(axis=0, ddof=1) / np.sqrt(len(group))
            if len(group) > 1
            else np.zeros_like(mean)
        )
        normalised = (mean - random) / (expert - random) if expert != random else mean * np.nan
        per_seed_normalised = (returns - random) / (expert - random)
        at = [int(np.flatnonzero(steps >= f * steps[-1])[0]) for f in FRACTIONS]
        out[name] = {
            "seeds": [m["seed"] for m in group],
            "steps": steps.tolist(),
            "mean_return": mean.tolist(),
            "stderr": se.tolist(),
            "expert_return": expert,
            "random_return": random,
            "final_return": float(mean[-1]),
            "steps_to_90": first_reaching(steps, mean, 0.9 * expert),
            "steps_to_90_per_seed": per_seed_90,
            "reached_90": len(reached),
            "median_steps_to_90": float(np.median(reached)) if reached else None,
            "stable_after_90": mean_se(
                [
                    float(np.mean(r[steps > first] >= 0.9 * expert)) if first is not None else None
                    for r, first in zip(returns, per_seed_90, strict=True)
                ]
            ),
            "steps_to_90_normalised": first_reaching(steps, normalised, 0.9),
            "steps_to_quarter": first_reaching(steps, normalised, 0.25),
            "steps_to_quarter_per_seed": [
                first_reaching(steps, r, 0.25) for r in per_seed_normalised
            ],
            "steps_to_half": first_reaching(steps, normalised, 0.5),
            "steps_to_half_per_seed": [first_reaching(steps, r, 0.5) for r in per_seed_normalised],
            "at_fraction": [
                {
                    "fraction": f,
                    "steps": int(steps[i]),
                    "mean": float(mean[i]),
                    "stderr": float(se[i]),
                }
                for f, i in zip(FRACTIONS, at, strict=True)
            ],
            "curve_mean": mean_se(returns.mean(axis=1).tolist()),
            "best": mean_se(returns.max(axis=1).tolist()),
            **{
                f"{key}_{when}": mean_se([rollout_average(m, key, when == "last") for m in group])
                for key in ("violation_rate", "entropy")
                for when in ("first", "last")
            },
        }
    return out


def evaluate_cooking_runs(runs: list[str | Path], out_dir: str | Path) -> dict:
    """Write report.json, report.md and report.png for the runs; return the report."""
    if not runs:
        raise InputError("no run directories given")
    out_dir = Path(out_dir)
    metrics = [read_run(r) for r in runs]
    variants = summarise(metrics)
    report = {"runs": [str(r) for r in runs], "variants": variants}
    held_out = summarise(metrics, "held_out")
    if held_out:
        report["held_out"] = held_out
    plain, tleaf = variants.get("none", {}), variants.get("tleaf", {})
    for key in ("steps_to_90", "steps_to_quarter", "steps_to_half"):
        if plain.get(key) is not None and tleaf.get(key) is not None and plain[key] > 0:
            report[f"tleaf_over_none_{key}"] = tleaf[key] / plain[key]
    if plain and tleaf:
        report["tleaf_over_none_median_steps_to_90"] = median_ratio(
            tleaf["steps_to_90_per_seed"], plain["steps_to_90_per_seed"]
        )
    out_dir.mkdir(parents=True, exist_ok=True)
    pools = [("demonstrated", variants)] + ([("held-out", held_out)] if held_out else [])
    _figure(pools, out_dir / "report.png")
    write_text_atomic(out_dir / "report.json", json.dumps(report, indent=2))
    write_text_atomic(out_dir / "report.md", _markdown(report))
    return report


def _markdown(report: dict) -> str:
    def steps(v: int | None) -> str:
        return "not reached" if v is None else str(v)

    def ms(v: dict | None) -> str:
        return "—" if v is None else f"{v['mean']:.2f} ± {v['stderr']:.2f}"

    pools = [("demonstrated", report["variants"])]
    if report.get("held_out"):
        pools.append(("held-out", report["held_out"]))
    lines = [
        "# GAIL on Creative Cooking (synthetic environment): return vs environment steps",
        "",
        "Per variant and evaluation pool (demonstrated: the demos' ingredient sets; held-out: "
        "sets no demo shows): seeds whose curve reached 90 % of the expert's return on that "
        "pool, the median of their first steps there, the share of their later evaluations "
        "still at 90 % or more (mean ± s.e. over those seeds), and the return (mean ± s.e. over "
        "seeds) at 25 / 50 / 100 % of the budget.",
        "",
        "| variant | seeds | pool | reached 90 % of expert | median steps to 90 % | later "
        "evaluations ≥ 90 % | return at 25 / 50 / 100 % of budget |",
        "|---|---|---|---|---|---|---|",
    ]
    for pool_name, variants in pools:
        for name, v in variants.items():
            median, stable = v["median_steps_to_90"], v["stable_after_90"]
            share = "—" if stable is None else f"{stable['mean']:.0%} ± {stable['stderr']:.0%}"
            at = " / ".join(f"{a['mean']:.2f} ± {a['stderr']:.2f}" for a in v["at_fraction"])
            lines.append(
                f"| {name} | {len(v['seeds'])} | {pool_name} | {v['reached_90']} of "
                f"{len(v['seeds'])} | {'—' if median is None else f'{median:,.0f}'} | "
                f"{share} | {at} |"
            )
    lines += [
        "",
        "On the demonstrated pool:",
        "",
        "| variant | seeds | final return (mean ± s.e.) | expert | random | steps to 90 % of "
        "expert (mean curve) | per seed | steps to 90 % normalised |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, v in report["variants"].items():
        per_seed = ", ".join(steps(s) for s in v["steps_to_90_per_seed"])
        lines.append(
            f"| {name} | {len(v['seeds'])} | {v['final_return']:.2f} ± {v['stderr'][-1]:.2f} | "
            f"{v['expert_return']:.2f} | {v['random_return']:.2f} | {steps(v['steps_to_90'])} | "
            f"{per_seed} | {steps(v['steps_to_90_normalised'])} |"
        )
    lines += [
        "",
        "Return at fixed steps (mean ± s.e. over seeds), and steps to a quarter and to half the "
        "way from the uniform policy to the expert, (R − R_random) / (R_expert − R_random) ≥ "
        "0.25 or 0.5 (mean curve; per seed):",
        "",
        "| variant | "
        + " | ".join(f"{f:.0%} of the budget" for f in FRACTIONS)
        + " | steps to a quarter | per seed | steps to half | per seed |",
        "|---|" + "---|" * (len(FRACTIONS) + 4),
    ]
    for name, v in report["variants"].items():
        cells = [f"{a['mean']:.2f} ± {a['stderr']:.2f} ({a['steps']})" for a in v["at_fraction"]]
        for key in ("steps_to_quarter", "steps_to_half"):
            cells += [steps(v[key]), ", ".join(steps(s) for s in v[f"{key}_per_seed"])]
        lines.append(f"| {name} | {' | '.join(cells)} |")
    lines += [
        "",
        f"Per run, then mean ± s.e. over seeds: the mean return over the whole curve, the best "
        f"evaluation, and (training log, first → last {ROLLOUTS} rollouts) the share of "
        "(episode, ingredient) rows whose sampled actions violate the rules (logged with a logic "
        "term; checker's is plain GAIL's) and the policy's entropy:",
        "",
        "| variant | mean over the curve | best evaluation | violation rate | entropy |",
        "|---|---|---|---|---|",
    ]
    for name, v in report["variants"].items():
        cells = [ms(v["curve_mean"]), ms(v["best"])]
        for key in ("violation_rate", "entropy"):
            cells.append(f"{ms(v[f'{key}_first'])} → {ms(v[f'{key}_last'])}")
        lines.append(f"| {name} | {' | '.join(cells)} |")
    lines.append("")
    for key, what in (
        ("steps_to_90", "90 % of the expert"),
        ("steps_to_quarter", "a quarter of the way"),
        ("steps_to_half", "half the way"),
    ):
        if f"tleaf_over_none_{key}" in report:
            lines.append(f"tleaf / none steps to {what}: {report[f'tleaf_over_none_{key}']:.2f}")
        elif "none" in report["variants"] and "tleaf" in report["variants"]:
            missing = [n for n in ("none", "tleaf") if report["variants"][n][key] is None]
            why = (
                f"{' and '.join(missing)} did not reach it within the budget"
                if missing
                else "none reached it at the first evaluation"
            )
            lines.append(f"tleaf / none steps to {what}: not measurable ({why})")
    if "tleaf_over_none_median_steps_to_90" in report:
        r = report["tleaf_over_none_median_steps_to_90"]

        def bound(v: float | None) -> str:
            return "∞" if v is None else f"{v:.2f}"

        if r["ratio"] is not None:
            point = f"{r['ratio']:.2f}"
        elif r["denominator_median"] is not None:
            point = "∞ (tleaf's median seed did not get there)"
        else:
            point = "undefined (none's median seed did not get there)"
        lines.append(
            f"tleaf / none median steps to 90 % of the expert, per seed (a seed that never got "
            f"there counts as never): {point}; 95 % bootstrap interval over seeds "
            f"{bound(r['low'])} – {bound(r['high'])} ({r['draws']:,} draws, "
            f"{r['undefined_draws']:,} undefined)"
        )
    lines += [
        "",
        "Figure: report.png (mean ± s.e. over seeds, one panel per evaluation pool; dashed: the "
        "expert's return, dotted: the uniform policy's).",
    ]
    return "\n".join(lines) + "\n"


def _figure(pools: list[tuple[str, dict]], path: Path) -> None:
    """One panel per evaluation pool: mean ± s.e. curves, the expert's and uniform's returns."""
    plt = pyplot()

    fig, axes = plt.subplots(1, len(pools), figsize=(6 * len(pools), 4), squeeze=False)
    for ax, (pool, variants) in zip(axes[0], pools, strict=True):
        for name, v in variants.items():
            steps, mean, se = (np.array(v[k]) for k in ("steps", "mean_return", "stderr"))
            label = f"GAIL + {name}" if name != "none" else "GAIL"
            ax.plot(steps, mean, label=f"{label} ({len(v['seeds'])} seeds)")
            ax.fill_between(steps, mean - se, mean + se, alpha=0.25)
        expert = np.mean([v["expert_return"] for v in variants.values()])
        ax.axhline(expert, color="black", linestyle="--", linewidth=1, label="expert")
        uniform = np.nanmean([v["random_return"] for v in variants.values()])
        if np.isfinite(uniform):
            ax.axhline(uniform, color="grey", linestyle=":", linewidth=1, label="uniform policy")
        ax.set_xlabel("environment steps")
        ax.set_ylabel("return (true reward)")
        ax.set_title(f"Creative Cooking (synthetic), {pool} ingredient sets")
        ax.legend(fontsize="small")
    fig.tight_layout()
    save_png(fig, path)
