"""The held-out ingredient pool: never demonstrated, fixed, and with expert returns."""

from __future__ import annotations

from tleaf_cli.tasks.cooking.demo_episodes import read_demo_episodes
from tleaf_cli.tasks.cooking.demos import DemoSettings, generate_demos
from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, load_domain
from tleaf_cli.tasks.cooking.pools import expert_returns, held_out_pool


def test_held_out_pool_never_overlaps_the_demonstrations_and_is_fixed(tmp_path) -> None:
    domain = load_domain(DEFAULT_DOMAIN)
    generate_demos(tmp_path / "demos.parquet", DemoSettings(episodes=6, seed=3))
    demos = read_demo_episodes(tmp_path / "demos.parquet", domain)
    shown = list(dict.fromkeys(e.ingredients for e in demos))
    pool = held_out_pool(domain, shown, 12)
    assert len(pool) == len(set(pool)) == 12
    assert not set(pool) & set(shown)
    names = [i.name for i in domain.ingredients]
    for s in pool:  # five distinct ingredients, in domain order, as the environment keeps them
        assert len(set(s)) == 5 and list(s) == sorted(s, key=names.index)
    assert held_out_pool(domain, shown, 12) == pool  # the same draw every time
    # Asking for more sets only adds to the pool: a run with 8 sets sees a prefix of one with 12.
    assert held_out_pool(domain, shown, 8) == pool[:8]
    # The planner that made the demos gives their returns again on the demonstrated sets.
    by_set = {e.ingredients: e.episode_return for e in demos}
    returns = expert_returns(domain, shown)
    assert returns == [by_set[s] for s in shown]  # shortest plans: one length, one return
    assert all(r > 0 for r in expert_returns(domain, pool))


def test_report_summarises_each_pool_against_its_own_expert() -> None:
    from tleaf_cli.tasks.cooking.gail_report import summarise

    def run(seed: int, demonstrated: list[float], held_out: list[float]) -> dict:
        curve = [
            {"steps": 1000 * i, "mean_return": d, "held_out_mean_return": h}
            for i, (d, h) in enumerate(zip(demonstrated, held_out, strict=True))
        ]
        return {
            "variant": "none", "seed": seed, "curve": curve,
            "expert_return": 10.0, "random_return": -90.0,
            "expert_return_held_out": 20.0, "random_return_held_out": -80.0,
        }  # fmt: skip

    runs = [run(0, [-90, 9.5, 5, 9.0], [-80, 0, 18, 19]), run(1, [-90, -50, 9.2, 9.4], [-80] * 4)]
    demonstrated, held_out = summarise(runs), summarise(runs, "held_out")
    d, h = demonstrated["none"], held_out["none"]
    assert d["steps_to_90_per_seed"] == [1000, 2000] and d["reached_90"] == 2  # bar 9.0
    assert d["median_steps_to_90"] == 1500
    # seed 0 after its first 9.5: 5 (below) and 9.0 (at the bar); seed 1: 9.4 -> 1.0
    assert d["stable_after_90"]["mean"] == (0.5 + 1.0) / 2
    assert h["steps_to_90_per_seed"] == [2000, None] and h["reached_90"] == 1  # bar 18
    assert h["expert_return"] == 20.0 and h["random_return"] == -80.0
    # a run that never evaluated on held-out sets is left out of that pool
    old = run(2, [-90, 0, 0, 0], [0] * 4)
    del old["expert_return_held_out"]
    assert summarise([*runs, old], "held_out")["none"]["seeds"] == [0, 1]
