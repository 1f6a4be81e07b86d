"""What a name must look like to be an atom of an LTLf formula (ltlf2dfa's grammar).

A base module, below logic/: `arguments` checks a model's output items with it, and
`logic/grammar.py` reads formulas with the same words, so neither imports the other.
"""

from __future__ import annotations

import re

ATOM = re.compile(r"[a-z][a-z0-9_]*")
AMBIGUOUS = ("true", "false", "last")  # lark reads these as a prefix of a longer word


def atom_problem(name: str) -> str | None:
    """Why `name` can never be an atom of a formula (so a rule can never name it), or None."""
    if not ATOM.fullmatch(name):
        return "atoms are lower-case ASCII letters, digits and _, starting with a letter"
    if name.startswith(AMBIGUOUS):
        return f"a word starting with {', '.join(AMBIGUOUS)} is read as a constant"
    return None
