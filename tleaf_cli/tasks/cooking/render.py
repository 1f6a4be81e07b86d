"""A text picture of a Creative Cooking state for people (the environment's `ansi` render mode)."""

from __future__ import annotations

from tleaf_cli.tasks.cooking.rules import EMPTY, NUM_SLOTS, EpisodeRules, State


def render_text(
    rules: EpisodeRules,
    state: State,
    last: tuple[str, bool] | None,
    steps: int,
    episode_return: float,
) -> str:
    """Slots with ingredient, status, required status and properties; the last action; the goal."""
    statuses = rules.domain.statuses

    def status_name(code: int) -> str:
        return "-" if code == EMPTY else statuses[code - 1]

    lines = [f"Creative Cooking  step {steps}  return {episode_return:+.0f}"]
    if last is None:
        lines.append("last action: none yet")
    else:
        name, feasible = last
        verdict = "feasible" if feasible else "INFEASIBLE, nothing changed"
        lines.append(f"last action: {name} ({verdict})")
    header = f"{'slot':<5}{'ingredient':<14}{'status':<16}{'required':<16}properties"
    lines += [header, "-" * len(header)]
    done = 0
    for slot in range(NUM_SLOTS):
        status = state[slot]
        name = rules.slot_name(slot)
        if status == EMPTY:
            where = "(empty)" if slot == 0 else "(merged away)"
            lines.append(f"{slot:<5}{name:<14}{where:<16}{'-':<16}")
            done += 1
            continue
        goal = rules.slot_goal(state, slot)
        done += status == goal
        mark = "ok" if status == goal else ""
        props = ", ".join(sorted(rules.properties(rules.slot_properties(state, slot))))
        lines.append(
            f"{slot:<5}{name:<14}{status_name(status):<16}{status_name(goal) + ' ' + mark:<16}"
            f"{props}"
        )
    verdict = "reached" if rules.is_goal(state) else f"not yet ({done} of {NUM_SLOTS} slots done)"
    lines.append(f"goal: {verdict}")
    return "\n".join(lines) + "\n"
