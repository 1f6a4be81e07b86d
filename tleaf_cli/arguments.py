"""The public API's argument checks: one place, called once per call at the boundary.

Every public function (`compile_formula`, `check`, `RuleSet`, `logic_loss`, `constrained_decode`,
`Shield`, `load_embedder` and what `Embedder` exposes) checks what it is given here before any
work, as PyTorch's functional API does: a value of the wrong type raises `ArgumentTypeError`
(a `TypeError` too), a value of the right type that cannot be used raises `ArgumentError` (a
`ValueError` too); both are `TleafError`s whose message names the argument, says what was given
and what to pass. Where a user's natural value is unambiguous it is accepted: lengths as a list
of ints, float16 / bfloat16 log-probabilities (computed in float32).

No check runs inside a loop over steps or sequences, and this module imports torch only in the
functions that check tensors (logic/ calls the others and never imports torch).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from typing import TYPE_CHECKING, Any

from tleaf_cli.atom_names import atom_problem
from tleaf_cli.errors import ArgumentError, ArgumentTypeError

if TYPE_CHECKING:
    import torch


def given(value: Any) -> str:
    """A short description of `value` for a message: its type, and a tensor's shape and dtype."""
    shape = getattr(value, "shape", None)
    dtype = getattr(value, "dtype", None)
    if shape is not None and dtype is not None:
        return f"{type(value).__name__} of shape {list(shape)} and dtype {dtype}"
    if isinstance(value, str):
        return f"the string {value[:40]!r}" + ("..." if len(value) > 40 else "")
    return type(value).__name__


def text(value: Any, argument: str) -> str:
    """`value` if it is a str, else ArgumentTypeError."""
    if not isinstance(value, str):
        raise ArgumentTypeError(argument, f"must be a str, not {given(value)}")
    return value


def sequence(value: Any, argument: str, what: str) -> Sequence:
    """`value` as a list if it is a sequence that is not a string (`what` says of what)."""
    if isinstance(value, str | bytes) or not isinstance(value, Sequence | tuple):
        raise ArgumentTypeError(argument, f"must be a sequence of {what}, not {given(value)}")
    return list(value)


def vocabulary(items: Any, argument: str = "vocabulary") -> tuple[str, ...]:
    """A model's output items: distinct strs, each one a possible atom (`atom_names.atom_problem`),
    since a rule names an item by its atom and a repeated item would be judged as one copy.
    A tuple that passed once passes again without a second look (a trainer builds every rule
    set of a run over the same vocabulary)."""
    if type(items) is tuple:
        try:
            if items in _VOCABULARIES:
                return items
        except TypeError:  # an unhashable item: the checks below name it
            pass
    items = sequence(items, argument, "item names (str)")
    seen: dict[str, int] = {}
    for i, item in enumerate(items):
        if not isinstance(item, str):
            raise ArgumentTypeError(argument, f"item {i} must be a str, not {given(item)}")
        problem = atom_problem(item)
        if problem is not None:
            raise ArgumentError(argument, f"item {i} {item!r} can never be an atom: {problem}")
        if item in seen:
            raise ArgumentError(
                argument, f"{item!r} appears twice (items {seen[item]} and {i}); items are distinct"
            )
        seen[item] = i
    if not items:
        raise ArgumentError(argument, "is empty; pass the model's output items")
    checked = tuple(items)
    if len(_VOCABULARIES) < 64:
        _VOCABULARIES.add(checked)
    return checked


def traces(value: Any, argument: str = "traces") -> list[Sequence[Collection[str]]]:
    """Traces: a sequence of traces, each a non-empty sequence of letters, each a collection
    (set, list, ...) of atom names; a str at any level is refused (it would be read letter by
    letter). Lists and tuples of sets pass on a fast path: the checker's batches are large."""
    out = sequence(value, argument, "traces (each a sequence of sets of atoms)")
    for i, trace in enumerate(out):
        if not (type(trace) in _TRACES and trace and {type(x) for x in trace} <= _LETTERS):
            _trace(trace, f"{argument}[{i}]")  # the slow look, which says what is wrong
    return out


_TRACES = {list, tuple}
_VOCABULARIES: set[tuple[str, ...]] = set()  # `vocabulary`'s tuples that passed
_LETTERS = {set, frozenset}


def _trace(trace: Any, argument: str) -> None:
    """ArgumentError / ArgumentTypeError for a trace that is not a non-empty sequence of
    collections of atom names."""
    trace = sequence(trace, argument, "letters (sets of atoms)")
    if not trace:
        raise ArgumentError(argument, "is empty: traces have at least one letter")
    for t, letter in enumerate(trace):
        if isinstance(letter, str) or not isinstance(letter, Collection):
            raise ArgumentTypeError(
                f"{argument}[{t}]",
                f"must be a set of atom names (e.g. {{'a'}}; set() for none), not {given(letter)}",
            )


def log_probs(value: Any, argument: str = "log_probs") -> torch.Tensor:
    """A float [B, T, V] tensor with no NaN and no +inf (−inf is a probability of 0); float16
    and bfloat16 come back as float32, the precision the losses compute in."""
    import torch

    if not isinstance(value, torch.Tensor):
        raise ArgumentTypeError(argument, f"must be a torch.Tensor [B, T, V], not {given(value)}")
    if not value.is_floating_point():
        raise ArgumentTypeError(argument, f"must be a float tensor, not {given(value)}")
    if value.dim() != 3 or 0 in value.shape:
        raise ArgumentError(argument, f"must be [B, T, V] with B, T, V ≥ 1, not {given(value)}")
    if value.dtype in (torch.float16, torch.bfloat16):
        value = value.float()
    bad = torch.isnan(value) | torch.isposinf(value)
    if bool(bad.any()):
        b, t, v = (int(i) for i in bad.nonzero()[0])
        raise ArgumentError(
            argument, f"holds {float(value[b, t, v])} at [{b}, {t}, {v}]: every value must be a "
            "log-probability (finite, or −inf for probability 0)"
        )  # fmt: skip
    return value


def soft_traces(value: Any, width: int, argument: str = "traces") -> list[torch.Tensor]:
    """Soft traces: a sequence of float [T_b, width] tensors of per-step probabilities (in
    [0, 1], T_b ≥ 1); float16 / bfloat16 ones come back as float32."""
    import torch

    out = sequence(value, argument, f"float tensors [T, {width}] of probabilities")
    for i, p in enumerate(out):
        name = f"{argument}[{i}]"
        if not isinstance(p, torch.Tensor) or not p.is_floating_point():
            raise ArgumentTypeError(name, f"must be a float tensor [T, {width}], not {given(p)}")
        if p.dim() != 2 or p.shape[1] != width or p.shape[0] == 0:
            raise ArgumentError(name, f"must be [T, {width}] with T ≥ 1, not {given(p)}")
        if p.dtype in (torch.float16, torch.bfloat16):
            out[i] = p = p.float()
        bad = torch.isnan(p) | (p < 0) | (p > 1)
        if bool(bad.any()):
            t, k = (int(j) for j in bad.nonzero()[0])
            raise ArgumentError(
                name, f"holds {float(p[t, k])} at [{t}, {k}]: probabilities are 0 to 1"
            )
    if not out:
        raise ArgumentError(argument, "is empty: pass one soft trace or more")
    return out


def lengths(value: Any, batch: int, steps: int, device: Any, argument: str = "lengths"):
    """Each sequence's length as a long [B] tensor on `device`, every one in 1..T; None: all T
    steps. A list, tuple or array of ints is accepted."""
    import torch

    if value is None:
        return torch.full((batch,), steps, dtype=torch.long, device=device)
    array_like = isinstance(value, torch.Tensor | Sequence) or hasattr(value, "__array__")
    if isinstance(value, str | bytes) or not array_like:
        raise ArgumentTypeError(
            argument, f"must be a tensor or a sequence of B ints, not {given(value)}"
        )
    try:
        out = torch.as_tensor(value, device=device)
    except (TypeError, ValueError, RuntimeError):
        raise ArgumentTypeError(
            argument, f"must be a tensor or a sequence of B ints, not {given(value)}"
        ) from None
    if out.dtype == torch.bool or out.is_floating_point() or out.is_complex():
        raise ArgumentTypeError(argument, f"must hold ints, not {given(out)}")
    if out.dim() != 1 or out.shape[0] != batch:
        raise ArgumentError(
            argument, f"must hold one length per sequence, [{batch}], not {list(out.shape)}"
        )
    out = out.long()
    wrong = (out < 1) | (out > steps)
    if bool(wrong.any()):
        b = int(wrong.nonzero()[0])
        raise ArgumentError(
            argument, f"sequence {b} has length {int(out[b])}: lengths are 1 to T = {steps}"
        )
    return out.to(device)


def rule_sets(value: Any, batch: int | None, kind: type, argument: str = "rules") -> list:
    """One rule set (an instance of `kind`, tl.RuleSet) or None per sequence: `value` is one for
    all, or a sequence of `batch` (None: a sequence of any length, one or more, without None)."""
    hint = "tl.RuleSet(formulas, vocabulary)"
    if isinstance(value, kind):
        return [value] * (batch or 1)
    if isinstance(value, str):
        raise ArgumentTypeError(argument, f"must be a {hint}, not a formula string {value!r}")
    out = sequence(value, argument, f"rule sets ({hint} or None)")
    for b, r in enumerate(out):
        if r is not None and not isinstance(r, kind):
            raise ArgumentTypeError(
                argument, f"item {b} must be a {hint} or None, not {given(r)}"
            )  # fmt: skip
    if batch is None:
        if not out or None in out:
            raise ArgumentError(argument, f"must hold one {hint} or more, and no None")
    elif len(out) != batch:
        raise ArgumentError(argument, f"{len(out)} rule sets for a batch of {batch} sequences")
    return out
