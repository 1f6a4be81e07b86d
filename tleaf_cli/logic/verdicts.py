"""The four verdicts of runtime verification (RV-LTL) for a case that is still running.

A rule's DFA, after the events of a running case (its prefix u), is in some state s. What the
rest of the case can still do to the rule is a property of s alone, so the verdict of every
state is computed once per DFA (`state_verdicts`), and a monitor only follows states:

- **permanently satisfied**: every continuation keeps the rule, the empty one included (every
  state reachable from s, s itself too, accepts): nothing that happens next can break it;
- **temporarily satisfied**: the case keeps the rule if it ends now (s accepts), but some
  continuation breaks it;
- **temporarily violated**: the case breaks the rule if it ends now, but some continuation
  keeps it (s does not accept, an accepting state is reachable);
- **permanently violated**: no continuation keeps it (no accepting state is reachable).

This is Bauer, Leucker and Schallhart's RV-LTL read on finite traces (LTLf), as Maggi,
Montali, Westergaard and van der Aalst (BPM 2011) monitor Declare constraints. A continuation
is any finite sequence of letters of the DFA's alphabet, so the verdicts assume every letter can
still happen: what a log's next event can really be is the model's business (the probability
that the rule holds when the case ends), not the verdict's. Numpy only.
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np

from tleaf_cli.logic.dfa import DFA


class Verdict(IntEnum):
    """A rule's verdict on a running case (module docstring); `str()` gives its words."""

    PERMANENTLY_SATISFIED = 0
    TEMPORARILY_SATISFIED = 1
    TEMPORARILY_VIOLATED = 2
    PERMANENTLY_VIOLATED = 3

    def __str__(self) -> str:
        return self.name.lower().replace("_", " ")

    @property
    def final(self) -> bool:
        """Nothing that happens next can change it."""
        return self in (Verdict.PERMANENTLY_SATISFIED, Verdict.PERMANENTLY_VIOLATED)

    @property
    def satisfied(self) -> bool:
        """The case keeps the rule if it ends now."""
        return self in (Verdict.PERMANENTLY_SATISFIED, Verdict.TEMPORARILY_SATISFIED)


def state_verdicts(dfa: DFA) -> np.ndarray:
    """int8 [S]: each state's `Verdict` (module docstring)."""
    live = dfa.live()  # some continuation keeps the rule
    breakable = dfa.reaches(~dfa.accepting)  # some continuation breaks it
    out = np.empty(dfa.num_states, dtype=np.int8)
    out[dfa.accepting & ~breakable] = Verdict.PERMANENTLY_SATISFIED
    out[dfa.accepting & breakable] = Verdict.TEMPORARILY_SATISFIED
    out[~dfa.accepting & live] = Verdict.TEMPORARILY_VIOLATED
    out[~dfa.accepting & ~live] = Verdict.PERMANENTLY_VIOLATED
    return out
