"""The node classes of ltlf2dfa's LTLf formulas, imported from ltlf2dfa in this one place.

A parsed formula (`formulas.parse`) is a tree of these 16 classes, `LTLfFormula` their base. The
modules that walk such trees node by node (`grammar`, `progression`, `semantics` and
`embed/graphs`) need every one of them; they read them from here as
`from tleaf_cli.logic import ltlf_nodes as ltlf` (`ltlf.LTLfAnd`). The classes are ltlf2dfa's
own (not copies), so an `isinstance` test holds on the trees ltlf2dfa's parser builds.
"""

from ltlf2dfa.ltlf import (  # noqa: F401  (re-exported: __all__)
    LTLfAlways,
    LTLfAnd,
    LTLfAtomic,
    LTLfEquivalence,
    LTLfEventually,
    LTLfFalse,
    LTLfFormula,
    LTLfImplies,
    LTLfLast,
    LTLfNext,
    LTLfNot,
    LTLfOr,
    LTLfRelease,
    LTLfTrue,
    LTLfUntil,
    LTLfWeakNext,
)

# The names above (computed, so the list is written once).
__all__ = sorted(name for name in dir() if name.startswith("LTLf"))
