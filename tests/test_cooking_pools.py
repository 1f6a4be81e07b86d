"""The held-out ingredient pool (issue 18): never demonstrated, fixed, and with expert returns."""

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
