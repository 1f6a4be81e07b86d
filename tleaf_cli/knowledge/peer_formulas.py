"""Di Francescomarino et al.'s a-priori formulas (BPM 2017) in tleaf's syntax.

Their `formulas.tsv` has one row per (log, kind): the log's name, STRONG or WEAK, the formula in
their LTL syntax — `[]` always, `<>` eventually, `/\\` and, `\\/` or, `->` implies, `!` not, `X`
next, `U` until, atoms quoted activity ids such as `"8"` — and the prefix lengths they evaluate
(from, to exclusive). `peer_formula` rewrites one formula token by token: `[]` -> `G`, `<>` ->
`F`, `/\\` -> `&`, `\\/` -> `|`, and each quoted activity -> its atom by
`data.activity_names.activity_atoms` (the map the event-log reader gives the same activities, so
`"8"` becomes `a8`), or by a map the caller gives (a log's own, where names collide). Every
formula it returns is read back by tleaf's parser first, so a formula of theirs with unbalanced
parentheses is an error naming its line, never a rule in a file no later stage reads.

**Finite traces.** They check a formula on a *completed* case, a finite sequence of activities;
their formulas use only always, eventually, and, implies. Read as LTLf on that finite trace — `F`
"at this step or a later one of the case", `G` "at this and every later step of the case" —
they mean exactly what they say of the case: `[]("8" -> <>"6") /\\ <>"8"` holds when 8 occurs and
every 8 is followed, within the case, by a 6. On a prefix of a running case the same formula is
not yet decided; tleaf decides it on the completed case, as they do.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass

from tleaf_cli.data.activity_names import activity_atoms
from tleaf_cli.errors import InputError
from tleaf_cli.logic.formulas import FormulaSyntaxError, parse

_TOKEN = re.compile(r'\s*(?:"(?P<atom>[^"]*)"|(?P<op>\[\]|<>|/\\|\\/|->|<->|!|\(|\)|X|U))')
_OPERATORS = {"[]": "G", "<>": "F", "/\\": "&", "\\/": "|", "->": "->", "<->": "<->"}
_OPERATORS.update({"!": "!", "(": "(", ")": ")", "X": "X", "U": "U"})
_UNARY = {"G", "F", "X", "!"}
KINDS = ("STRONG", "WEAK")  # the kinds of their formulas, as their file spells them


def _tokens(text: str) -> list[re.Match]:
    out, pos = [], 0
    while text[pos:].strip():
        m = _TOKEN.match(text, pos)
        if m is None:
            raise InputError(
                f"formula '{text}': cannot read '{text[pos:].strip()[:20]}' at column {pos + 1}"
            )
        out.append(m)
        pos = m.end()
    return out


def peer_formula(text: str, atoms: Mapping[str, str] | None = None) -> str:
    """`text` (their syntax) in tleaf's syntax; activities become atoms by `atoms` (default:
    `activity_atoms` of the activities the formula quotes). InputError for text it cannot read,
    an activity `atoms` lacks, or a result tleaf's parser does not read (every formula returned
    parses)."""
    tokens = _tokens(text)
    if atoms is None:
        atoms = activity_atoms(m.group("atom") for m in tokens if m.group("atom") is not None)
    out: list[str] = []
    for m in tokens:
        name = m.group("atom")
        if name is not None:
            if name not in atoms:
                raise InputError(f"formula '{text}': activity \"{name}\" has no atom")
            token = atoms[name]
        else:
            token = _OPERATORS[m.group("op")]
        glued = out and (
            out[-1] in ("(", "!") or token == ")" or (out[-1] in _UNARY and token == "(")
        )
        if out and not glued:
            out.append(" ")
        out.append(token)
    formula = "".join(out)
    try:
        parse(formula)  # what is written must read back: unbalanced parentheses, `F` alone
    except FormulaSyntaxError as e:
        raise InputError(
            f"formula '{text}' is '{formula}' in tleaf's syntax, which does not parse: {e}"
        ) from None
    return formula


@dataclass(frozen=True)
class PeerFormula:
    """One row of their formulas.tsv, converted."""

    log: str
    kind: str  # one of KINDS
    original: str
    formula: str  # tleaf's syntax
    prefix_lengths: tuple[int, int] | None  # (from, to exclusive)

    @property
    def name(self) -> str:
        """The rule's name in a `.ltl` file: `helpdesk.strong`."""
        return f"{self.log}.{self.kind.lower()}"


def read_peer_formulas(
    text: str, atoms: Mapping[str, str] | None = None, log: str | None = None
) -> list[PeerFormula]:
    """Every row of a formulas.tsv text (a header line first), converted (only `log`'s rows when
    given); InputError naming the line for a row with fewer than three columns, a bad log name,
    a kind other than STRONG or WEAK (exactly), prefix lengths that are not two whole numbers
    from < to (both blank: none), or a formula it cannot convert to one that parses."""
    out: list[PeerFormula] = []
    lines = text.split("\n")
    for lineno, raw in enumerate(lines[1:], start=2):
        line = raw.rstrip("\r")
        if not line.strip():
            continue
        cells = line.split("\t")
        if len(cells) < 3:
            raise InputError(f"line {lineno}: expected log, kind, formula separated by tabs")
        name, kind, original = (c.strip() for c in cells[:3])
        if log is not None and name != log:
            continue
        try:
            if not re.fullmatch(r"[A-Za-z0-9_-]+", name):
                raise InputError(f"log '{name}' is not a name (letters, digits, _ and -)")
            if kind not in KINDS:
                raise InputError(f"kind '{kind}' is neither {' nor '.join(KINDS)}")
            lengths = _prefix_lengths(cells[3:5])
            formula = peer_formula(original, atoms)
        except InputError as e:
            raise InputError(f"line {lineno}: {e}") from None
        out.append(PeerFormula(name, kind, original, formula, lengths))
    names = [p.name for p in out]
    repeated = {n for n in names if names.count(n) > 1}
    if repeated:
        raise InputError(f"(log, kind) {sorted(repeated)[0]} appears twice")
    return out


def _prefix_lengths(cells: list[str]) -> tuple[int, int] | None:
    """The row's prefix lengths (from, to exclusive), None when both cells are blank or absent;
    InputError for anything but two whole numbers with from < to."""
    low, high = ([c.strip() for c in cells] + ["", ""])[:2]
    if not low and not high:
        return None
    if not (re.fullmatch(r"[0-9]+", low) and re.fullmatch(r"[0-9]+", high)):
        raise InputError(
            f"prefix lengths '{low}' and '{high}' are not whole numbers (from, to exclusive)"
        )
    if int(low) >= int(high):
        raise InputError(f"prefix lengths from {low} to {high} (exclusive) name none")
    return int(low), int(high)


def peer_ltl_text(formulas: list[PeerFormula], header: list[str]) -> str:
    """A `.ltl` file of the converted formulas: `header` as comments, then per row a comment
    with their original text and prefix lengths, and the named rule."""
    lines = [f"# {h}" if h else "#" for h in header]
    for p in formulas:
        lengths = ""
        if p.prefix_lengths is not None:
            lengths = f"; prefix lengths {p.prefix_lengths[0]} to {p.prefix_lengths[1] - 1}"
        lines.append(f"# {p.original}{lengths}")
        lines.append(f"{p.name}: {p.formula}")
    return "\n".join(lines) + "\n"
