"""An event log's activity names as atoms of LTLf formulas.

Activities in real logs are named for people ("Assign seriousness", "W_Completeren aanvraag",
"3", "Ärztliche Prüfung", "検査"); a formula's atoms are lower-case ASCII letters, digits and _,
starting with a letter (`tleaf_cli.atom_names`). `activity_atoms` gives every activity an atom that
is readable (the same words, transliterated to ASCII by anyascii, lower case, joined by _),
deterministic (it depends on the set of names, not on their order) and unique (names that meet,
such as "Check in" and "Check-in", get _2, _3, ...), so a rule mined from or written for a log
names its activities by atoms a person can read back.

The map is made once, from the log's names, and kept with the cases artifact; every reader of
rules for that log takes its atoms from it (`bind_atoms`): a name a rule file writes is matched
to the log's names exactly, never folded again on its own.
"""

from __future__ import annotations

import hashlib
import re
import unicodedata
from collections.abc import Iterable, Mapping

from anyascii import anyascii

from tleaf_cli.atom_names import AMBIGUOUS, atom_problem

_NOT_WORD = re.compile(r"[^a-z0-9]+")
_FALLBACK = "activity"  # the atom of a name with no ASCII letter or digit at all


def activity_atom(name: str) -> str:
    """The atom `name` reads as, before names that meet are told apart (see `activity_atoms`).

    Letters outside ASCII are transliterated ("Réunion" -> "reunion", "Straße" -> "strasse",
    "Проверка" -> "proverka"; a syllabic character is a word of its own: "検査" -> "jian_zha"),
    other characters outside ASCII letters and digits separate words; a name starting with a
    digit, or with a word the formula grammar reads as a constant (true, false, last), gets "a"
    in front ("3" -> "a3", "last step" -> "alast_step").
    """
    atom = _NOT_WORD.sub("_", _ascii(name).lower()).strip("_")
    if not atom:
        return _FALLBACK
    if not atom[0].isalpha() or atom.startswith(AMBIGUOUS):
        atom = "a" + atom
    assert atom_problem(atom) is None, atom
    return atom


def _ascii(name: str) -> str:
    """`name` in ASCII: a Latin letter as its base letter, any other character by anyascii, a
    character of a script without letters (CJK) as a word of its own."""
    parts = []
    for char in unicodedata.normalize("NFC", name):
        if char.isascii():
            parts.append(char)
            continue
        text = anyascii(char)
        latin = unicodedata.name(char, "").startswith("LATIN")
        parts.append(text if latin or len(text) <= 1 else f" {text} ")
    return "".join(parts)


def activity_atoms(names: Iterable[str]) -> dict[str, str]:
    """Each distinct activity name -> its atom: readable, deterministic and unique.

    Names that are atoms already keep themselves; the others take `activity_atom(name)`, and where
    that is taken, the first free of `<atom>_2`, `<atom>_3`, ... Names are served in sorted order,
    so the map depends only on the set of names.
    """
    distinct = sorted(set(names))
    used: set[str] = set()
    out: dict[str, str] = {}
    for name in distinct:  # names that are atoms already keep themselves
        if atom_problem(name) is None:
            out[name] = name
            used.add(name)
    for name in distinct:
        if name not in out:
            out[name] = free_atom(activity_atom(name), used)
    return {name: out[name] for name in distinct}


def free_atom(base: str, used: set[str]) -> str:
    """The first of `base`, `base_2`, `base_3`, ... not in `used`, added to it."""
    atom, n = base, 2
    while atom in used:
        atom, n = f"{base}_{n}", n + 1
    used.add(atom)
    return atom


def folded(atoms: Mapping[str, str]) -> list[list[str]]:
    """The groups of names (two or more, each sorted) that read as one word and were told apart
    by `_2`, `_3`, ... in `atoms` (name -> atom): what a person should know of the map."""
    groups: dict[str, list[str]] = {}
    for name in sorted(atoms):
        groups.setdefault(activity_atom(name), []).append(name)
    return [names for names in groups.values() if len(names) > 1]


def bind_atoms(names: Iterable[str], log: Mapping[str, str] | None = None) -> dict[str, str]:
    """Each of `names` (as a rule file writes them) -> its atom, under a log's map `log` (name ->
    atom, `activity_atoms` of the log's names, kept with its cases artifact).

    A name the log has takes the log's atom: matched exactly, character for character, so
    "Check-in" is never "Check in". A name the log does not have takes an atom of its own, apart
    from every atom of the log's and of the other names, so a rule on it reads an activity that
    never happens, never another one. Without a log, `activity_atoms(names)`."""
    distinct = list(dict.fromkeys(names))
    if log is None:
        return activity_atoms(distinct)
    out = {name: log[name] for name in distinct if name in log}
    missing = [name for name in distinct if name not in log]
    if missing:
        used = set(log.values())
        for name in sorted(missing):
            out[name] = free_atom(name if atom_problem(name) is None else activity_atom(name), used)
    return {name: out[name] for name in distinct}


def attribute_atom(attribute: str, value: object) -> str:
    """The atom of "this event's `attribute` is `value`" (MP-Declare's conditions, events with
    attributes): the attribute's and the value's words joined by a double _, which no activity
    atom holds ("org:resource", "Value 3" -> "org_resource__value_3"; "amount", 3 ->
    "amount__3"). An event makes its activity atom and one such atom per attribute true."""
    text = str(value)
    value_words = activity_atom(text)
    if value_words == _FALLBACK:  # no ASCII letter or digit ("-"): the value's bytes, hashed
        value_words = "v" + hashlib.sha1(text.encode()).hexdigest()[:8]
    elif text[:1].isdigit():
        value_words = value_words[1:]  # "3" reads "a3" as an atom's start; here it follows "__"
    return f"{activity_atom(attribute)}__{value_words}"
