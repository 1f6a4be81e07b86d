"""tleaf: temporal knowledge in LTLf, compiled to automata and embedded for deep sequence models.

The public Python API (docs/design.md, "Python API"), for ``import tleaf_cli as tl``:

* ``tl.compile_formula(text, alphabet="powerset" | "one-hot") -> tl.DFA``  minimal
* ``tl.check(dfa, traces) -> np.ndarray[bool]``                           exact, batched
* ``tl.RuleSet(formulas, vocabulary)``   the conjunction of formulas, one DFA over a one-hot
  vocabulary (a model's output items)
* ``tl.logic_loss(kind, log_probs, rules, lengths=None, embedder=None, reduction="mean")``
  ``"exact"`` (−log P(rules hold)), ``"tleaf"`` (the paper's ‖q(A_φ) − q(w̃)‖²) or ``"checker"``
* ``tl.constrained_decode(log_probs, rules, lengths=None)``  per sequence, the most probable
  sequence the rules accept (Viterbi over steps × DFA states)
* ``tl.Shield(rules)``                   a runtime monitor: which actions keep the rules satisfiable
* ``tl.load_embedder(model_dir)``        a trained q (a train-meta folder)
* ``tl.read_log(path or DataFrame, attributes=())``  an event log's cases (XES, CSV, a cases
  artifact, or a pandas DataFrame with pm4py's column names)
* ``tl.read_rules(path, cases=None)``     a knowledge base (`.ltl`, `.decl`), names matched to
  the log's
* ``tl.check_cases(cases, rules)``        every case against every rule: a DataFrame
* ``tl.load_run(run_dir, rules=None)``    a next-activity run; ``.predict(cases)``: tleaf
  predict's rows for running cases, a DataFrame
* ``tl.TleafError``                      every error the library raises on purpose

Names load on first use, so ``import tleaf_cli`` (and every CLI command) stays fast and torch is
imported only by what needs it. See docs/library.md.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from tleaf_cli import deferred_imports  # noqa: F401  (first: it keeps sympy from loading)
from tleaf_cli.version import __version__ as __version__  # re-exported

# public name -> the module that defines it
_PUBLIC = {
    "compile_formula": "tleaf_cli.logic.compile",
    "DFA": "tleaf_cli.logic.dfa",
    "check": "tleaf_cli.logic.checker",
    "RuleSet": "tleaf_cli.rule_set",
    "logic_loss": "tleaf_cli.losses.logic_loss",
    "constrained_decode": "tleaf_cli.decode",
    "Shield": "tleaf_cli.shield",
    "load_embedder": "tleaf_cli.embed.load",
    "TleafError": "tleaf_cli.errors",
    "read_log": "tleaf_cli.tasks.event_log_api",
    "read_rules": "tleaf_cli.tasks.event_log_api",
    "check_cases": "tleaf_cli.tasks.event_log_api",
    "load_run": "tleaf_cli.tasks.event_log_api",
}
__all__ = [
    "DFA",
    "RuleSet",
    "Shield",
    "TleafError",
    "check",
    "check_cases",
    "compile_formula",
    "constrained_decode",
    "load_embedder",
    "load_run",
    "logic_loss",
    "read_log",
    "read_rules",
]

if TYPE_CHECKING:  # for type checkers and editors; at run time `__getattr__` loads them
    from tleaf_cli.decode import constrained_decode
    from tleaf_cli.embed.load import load_embedder
    from tleaf_cli.errors import TleafError
    from tleaf_cli.logic.checker import check
    from tleaf_cli.logic.compile import compile_formula
    from tleaf_cli.logic.dfa import DFA
    from tleaf_cli.losses.logic_loss import logic_loss
    from tleaf_cli.rule_set import RuleSet
    from tleaf_cli.shield import Shield
    from tleaf_cli.tasks.event_log_api import check_cases, load_run, read_log, read_rules


def __getattr__(name: str) -> Any:
    if name in _PUBLIC:
        value = getattr(importlib.import_module(_PUBLIC[name]), name)
        globals()[name] = value  # later lookups skip this function
        return value
    raise AttributeError(f"module 'tleaf_cli' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_PUBLIC])
