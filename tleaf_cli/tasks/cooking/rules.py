"""Creative Cooking's rules for one episode: action encoding, feasibility, transitions, the goal.

Pure Python and deterministic, shared by the Gymnasium environment, the expert planner and the
tests, so all three agree by construction.

Slots: 0 is the mixture, 1..5 the episode's ingredients (the observation's order).
A state is a tuple of 7 ints: the 6 slots' status codes (0 empty, 1 raw .. 6 post-processed;
the mixture is empty until something is added) and, last, the bitmask of the properties put
into the mixture (bit k = domain.properties[k]).

Action ids (one `spaces.Discrete` for the whole domain, the same in every episode): the domain's
actions in file order; a unary action takes 6 ids, (action, slot) for slot 0..5; a binary action
takes 30, (action, slot1, slot2) for the ordered pairs of distinct slots in lexicographic order.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import cached_property

from tleaf_cli.errors import InputError
from tleaf_cli.tasks.cooking.domain import (
    MIXTURE,
    Action,
    ArgumentRule,
    Domain,
    Ingredient,
    atom,
)

NUM_SLOTS = 6  # the mixture and 5 ingredients
NUM_INGREDIENTS = NUM_SLOTS - 1
EMPTY = 0

State = tuple[int, ...]


@dataclass(frozen=True)
class ActionCodec:
    """The mapping between action ids and (action, slots) for a domain."""

    domain: Domain

    @cached_property
    def table(self) -> tuple[tuple[Action, tuple[int, ...]], ...]:
        rows = []
        for action in self.domain.actions:
            if action.arity == 1:
                rows += [(action, (s,)) for s in range(NUM_SLOTS)]
            else:
                pairs = [(a, b) for a in range(NUM_SLOTS) for b in range(NUM_SLOTS) if a != b]
                rows += [(action, p) for p in pairs]
        return tuple(rows)

    @cached_property
    def _ids(self) -> dict[tuple[str, tuple[int, ...]], int]:
        return {(a.name, slots): i for i, (a, slots) in enumerate(self.table)}

    @property
    def n(self) -> int:
        return len(self.table)

    def decode(self, action_id: int) -> tuple[Action, tuple[int, ...]]:
        """(action, slots) of an id; slots has one entry per argument."""
        return self.table[action_id]

    def encode(self, action: str, *slots: int) -> int:
        """The id of `action` applied to `slots`; KeyError for a wrong arity or equal slots."""
        return self._ids[(action, tuple(slots))]


def decode_action(domain: Domain, action_id: int) -> tuple[str, tuple[int, ...]]:
    """(action name, slots) for an action id of `domain`."""
    action, slots = ActionCodec(domain).decode(action_id)
    return action.name, slots


def encode_action(domain: Domain, action: str, *slots: int) -> int:
    """The action id of `action` on `slots` (0 = mixture, 1..5 = ingredients) in `domain`."""
    return ActionCodec(domain).encode(action, *slots)


class EpisodeRules:
    """Feasibility and effects of every action for one episode's five ingredients."""

    def __init__(
        self, domain: Domain, ingredients: Sequence[Ingredient], codec: ActionCodec | None = None
    ) -> None:
        if len(ingredients) != NUM_INGREDIENTS or len(set(ingredients)) != NUM_INGREDIENTS:
            raise InputError(f"an episode has {NUM_INGREDIENTS} distinct ingredients")
        self.domain = domain
        self.ingredients = tuple(ingredients)
        self.codec = codec or ActionCodec(domain)
        self._bit = {p: 1 << k for k, p in enumerate(domain.properties)}
        self._required: dict[int, int] = {}
        self._admitted: dict[tuple[ArgumentRule, int, int, int], bool] = {}
        self._unary_cache: dict[tuple[int, int, int, int], tuple[int, ...]] = {}
        table = self.codec.table
        self._unary_ids = [
            [i for i, (a, slots) in enumerate(table) if a.arity == 1 and slots == (slot,)]
            for slot in range(NUM_SLOTS)
        ]
        self._binary_ids = [(i, *slots) for i, (a, slots) in enumerate(table) if a.arity == 2]
        # Slot 0 (the mixture) has no fixed properties; its entries here are never used.
        self.masks = (0, *(self.mask(i.properties) for i in self.ingredients))
        self.goals = (0, *(self.required_code(m) for m in self.masks[1:]))

    # -- names -----------------------------------------------------------------------------

    def slot_name(self, slot: int) -> str:
        return MIXTURE if slot == 0 else self.ingredients[slot - 1].name

    def action_name(self, action_id: int) -> str:
        """The action's atom for this episode, e.g. `wash_lettuce`, `top_with_beef_salt`."""
        action, slots = self.codec.decode(action_id)
        return atom(action.name, *(self.slot_name(s) for s in slots))

    @cached_property
    def action_names(self) -> tuple[str, ...]:
        return tuple(self.action_name(i) for i in range(self.codec.n))

    # -- properties and goals ----------------------------------------------------------------

    def mask(self, properties) -> int:
        out = 0
        for p in properties:
            out |= self._bit[p]
        return out

    def properties(self, mask: int) -> frozenset[str]:
        return frozenset(p for p, b in self._bit.items() if mask & b)

    def required_code(self, mask: int) -> int:
        """Status code an ingredient or mixture with these properties must end in."""
        if mask not in self._required:
            required = self.domain.required_status(self.properties(mask))
            self._required[mask] = self.domain.status_code(required)
        return self._required[mask]

    def slot_properties(self, state: State, slot: int) -> int:
        return state[-1] if slot == 0 else self.masks[slot]

    def slot_goal(self, state: State, slot: int) -> int:
        return self.required_code(state[-1]) if slot == 0 else self.goals[slot]

    # -- the rules -------------------------------------------------------------------------

    def initial_state(self) -> State:
        raw = self.domain.status_code(self.domain.statuses[0])
        return (EMPTY, *([raw] * NUM_INGREDIENTS), 0)

    def is_goal(self, state: State) -> bool:
        """Every non-empty slot (the mixture included) is exactly at its required status."""
        return all(state[s] in (EMPTY, self.slot_goal(state, s)) for s in range(NUM_SLOTS))

    def _admits(self, rule: ArgumentRule, state: State, slot: int) -> bool:
        """Affordance and pre-requisite of `rule` for the ingredient (or mixture) in `slot`."""
        return self.admits(
            rule, self.slot_properties(state, slot), state[slot], self.slot_goal(state, slot)
        )

    def admits(self, rule: ArgumentRule, mask: int, status: int, goal: int) -> bool:
        """Whether something with these properties, status and required status may take `rule`."""
        if status == EMPTY:
            return False
        key = (rule, mask, status, goal)
        if key not in self._admitted:
            names = self.domain.statuses
            self._admitted[key] = rule.admits(
                self.properties(mask), names[status - 1], names[goal - 1]
            )
        return self._admitted[key]

    def status_moves(self, slot: int, status: int) -> set[int]:
        """Statuses one action can give the ingredient in `slot` (1..5) from `status`, on its own.

        Unary status actions, and top-with with this ingredient as the target (as if a ready
        topping were at hand): the moves a lower bound on its remaining actions may use.
        """
        mask, goal = self.masks[slot], self.goals[slot]
        return {
            self._result(a)
            for a in self.domain.actions
            if a.result is not None and self.admits(a.first, mask, status, goal)
        }

    def can_merge(self, slot: int, status: int) -> bool:
        """Whether the ingredient in `slot` (1..5) may go into the mixture at `status`."""
        mask, goal = self.masks[slot], self.goals[slot]
        return any(
            self.admits(a.first, mask, status, goal)
            for a in self.domain.actions
            if a.category in ("add", "combine")
        )

    def step(self, state: State, action_id: int) -> State | None:
        """The next state, or None when the action is infeasible (the state stays as it is)."""
        action, slots = self.codec.decode(action_id)
        category = action.category
        if category in ("add", "combine"):
            if 0 in slots or not all(self._admits(action.first, state, s) for s in slots):
                return None
            for s in slots:
                state = self._add(state, s)
            return state
        if category == "top-with":
            target, topping = slots
            if topping == 0 or not (
                self._admits(action.first, state, target)
                and self._admits(action.second, state, topping)
            ):
                return None
            return self._set(self._set(state, topping, EMPTY), target, self._result(action))
        (slot,) = slots
        if not self._admits(action.first, state, slot):
            return None
        return self._set(state, slot, self._result(action))

    def feasible(self, state: State) -> list[bool]:
        """For every action id, whether it is feasible in `state` (an action mask)."""
        return [self.step(state, a) is not None for a in range(self.codec.n)]

    def successors(self, state: State) -> Iterator[tuple[int, State]]:
        """(action id, next state) for every feasible action, in action-id order per slot.

        The same as trying `step` with every id, but unary actions are looked up by the slot's
        (properties, status), and binary ones skip empty slots: the planner's inner loop.
        """
        for slot in range(NUM_SLOTS):
            if state[slot] == EMPTY:
                continue
            key = (
                slot,
                self.slot_properties(state, slot),
                state[slot],
                self.slot_goal(state, slot),
            )
            if key not in self._unary_cache:
                ids = self._unary_ids[slot]
                self._unary_cache[key] = tuple(a for a in ids if self.step(state, a) is not None)
            for a in self._unary_cache[key]:
                yield a, self.step(state, a)
        for a, first, second in self._binary_ids:
            if state[first] != EMPTY and state[second] != EMPTY:
                nxt = self.step(state, a)
                if nxt is not None:
                    yield a, nxt

    def _result(self, action: Action) -> int:
        return self.domain.status_code(action.result)

    def _add(self, state: State, slot: int) -> State:
        """Put the ingredient in `slot` into the mixture.

        The mixture takes the lower-ranked status of the two (the ingredient's when the mixture is
        empty); an ingredient at its own required status does not lower it.
        """
        mixture, status = state[0], state[slot]
        if mixture == EMPTY:
            mixed = status
        elif status == self.goals[slot]:
            mixed = mixture
        else:
            mixed = min(mixture, status)
        out = list(state)
        out[0], out[slot], out[-1] = mixed, EMPTY, state[-1] | self.masks[slot]
        return tuple(out)

    @staticmethod
    def _set(state: State, slot: int, status: int) -> State:
        out = list(state)
        out[slot] = status
        return tuple(out)
