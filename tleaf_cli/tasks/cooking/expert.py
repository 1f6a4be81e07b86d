"""The expert: shortest plans for Creative Cooking episodes by A* over the exact rules.

The environment is deterministic and an episode's state space is finite (6 slot statuses and the
mixture's properties), so an optimal plan is a shortest path from the reset state to a goal state.
A* with an admissible heuristic returns one while expanding far fewer states than breadth-first
search (docs/cooking.md has the numbers).

The heuristic counts, for each ingredient still in its own slot and not at its required status,
the fewest actions that must touch it: either the status actions that bring it to its goal on its
own, or those that make it fit for the mixture plus half an action (a combine moves two
ingredients at once), plus one action on the mixture when the mixture will be below its required
status. It never overestimates, so A* (which re-opens a state reached more cheaply) returns a plan
of minimal length; the tests compare it with breadth-first search.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections import deque
from collections.abc import Iterable

import numpy as np

from tleaf_cli.tasks.cooking.rules import EMPTY, NUM_SLOTS, EpisodeRules, State

INF = math.inf


class NoPlan(RuntimeError):
    """The goal cannot be reached from the state (never for a checked domain's reset state)."""


def plan(
    rules: EpisodeRules, start: State | None = None, rng: np.random.Generator | None = None
) -> list[int]:
    """A shortest list of action ids from `start` (default: the reset state) to a goal state.

    Many plans are equally short (wash or rinse; dress or fry before plating). Without `rng` the
    lowest action ids win ties; with it, ties are broken at random (still a shortest plan), so
    demonstrations show the variety the rules allow. Deterministic for a given `rng` state.
    """
    start = rules.initial_state() if start is None else start
    bound = _LowerBound(rules)
    # Among equal f = g + h, deeper states first (they are nearer a goal), then the tie key.
    tie = itertools.count() if rng is None else iter(rng.random, None)
    frontier = [(bound(start), 0, next(tie), start)]
    parent: dict[State, tuple[State, int] | None] = {start: None}
    cost = {start: 0}
    while frontier:
        _, depth, _, state = heapq.heappop(frontier)
        g = -depth
        if g > cost[state]:
            continue  # a stale entry: the state was reached more cheaply since
        if rules.is_goal(state):
            return _walk_back(parent, state)
        successors = list(rules.successors(state))
        if rng is not None:  # which of several equivalent actions labels a step
            successors = [successors[i] for i in rng.permutation(len(successors))]
        for action, nxt in successors:
            if cost.get(nxt, INF) <= g + 1:
                continue
            cost[nxt], parent[nxt] = g + 1, (state, action)
            heapq.heappush(frontier, (g + 1 + bound(nxt), -(g + 1), next(tie), nxt))
    raise NoPlan("no sequence of actions reaches the goal")


def plan_breadth_first(rules: EpisodeRules, start: State | None = None) -> list[int]:
    """A shortest plan by plain breadth-first search: slow, the reference the tests compare with."""
    start = rules.initial_state() if start is None else start
    parent: dict[State, tuple[State, int] | None] = {start: None}
    queue = deque([start])
    while queue:
        state = queue.popleft()
        if rules.is_goal(state):
            return _walk_back(parent, state)
        for action, nxt in rules.successors(state):
            if nxt not in parent:
                parent[nxt] = (state, action)
                queue.append(nxt)
    raise NoPlan("no sequence of actions reaches the goal")


def _walk_back(parent: dict[State, tuple[State, int] | None], state: State) -> list[int]:
    actions = []
    while (link := parent[state]) is not None:
        state, action = link
        actions.append(action)
    return actions[::-1]


class _LowerBound:
    """The A* heuristic: a lower bound on the actions still needed (see the module docstring)."""

    def __init__(self, rules: EpisodeRules) -> None:
        self.rules = rules
        statuses = range(1, len(rules.domain.statuses) + 1)
        # Per ingredient slot and status, the fewest status actions on it to reach: its goal
        # (alone); a status below / above its goal (by rank) at which it may enter the mixture.
        self.alone, self.below, self.above = [None], [None], [None]
        for slot in range(1, NUM_SLOTS):
            goal = rules.goals[slot]
            fits = {s for s in statuses if rules.can_merge(slot, s)}
            self.alone.append(_distances(rules, slot, statuses, {goal}))
            self.below.append(_distances(rules, slot, statuses, {s for s in fits if s < goal}))
            self.above.append(_distances(rules, slot, statuses, {s for s in fits if s > goal}))
        self._cache: dict[State, int] = {}

    def __call__(self, state: State) -> int:
        if state not in self._cache:
            self._cache[state] = self._compute(state)
        return self._cache[state]

    def _compute(self, state: State) -> int:
        rules = self.rules
        if rules.is_goal(state):
            return 0
        # Two cases for a plan from here. (a) No unfinished ingredient goes into the mixture below
        # its goal: each needs its own actions, or goes in above its goal (half a combine at
        # least). (b) One does: the mixture is then below what it requires, and only an action
        # on the mixture itself can raise it (adding never raises the mixture's status).
        # A mixture already below its requirement needs such an action in both cases.
        without, with_low = 0.0, 0.0
        for slot in range(1, NUM_SLOTS):
            status = state[slot]
            if status in (EMPTY, rules.goals[slot]):
                continue
            alone = self.alone[slot][status]
            above = self.above[slot][status] + 0.5
            without += min(alone, above)
            with_low += min(alone, above, self.below[slot][status] + 0.5)
        mixture_low = int(state[0] != EMPTY and state[0] < rules.slot_goal(state, 0))
        best = min(without + mixture_low, with_low + 1)
        if best == INF:
            return _DEAD_END
        return max(math.ceil(best), 1)


_DEAD_END = 10**9  # no goal is reachable from such a state


def _distances(rules: EpisodeRules, slot: int, statuses: Iterable[int], targets: set[int]) -> dict:
    """Fewest status actions on `slot` alone from each status to one of `targets`."""
    edges = {s: rules.status_moves(slot, s) for s in statuses}
    dist = {s: 0 if s in targets else INF for s in edges}
    changed = True
    while changed:  # Bellman-Ford on at most 6 nodes
        changed = False
        for s, nexts in edges.items():
            best = min((dist[n] + 1 for n in nexts), default=INF)
            if best < dist[s]:
                dist[s], changed = best, True
    return dist
