"""Settings of the meta embedder q_m (`tleaf train-meta`): fields, presets, saved versions.

`MetaSettings()` is preset `best`, the q behind the Table I pipeline's figures;
`MetaSettings.preset("paper")` the 2021 paper's. A model folder's config.json stores the
resolved settings with `SETTINGS_VERSION`; `settings_from_config` reads every version.
Pure Python: the command line builds train-meta's options from this module.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, ClassVar

from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.settings import DEVICES, SCHEDULES, Presets, check_values, default_of, setting

EMBEDDERS = ("dfa", "syntax")
ENCODERS = ("tleaf", "authors")  # embed/automaton.py's AutomatonEncoder, embed/paper_encoder.py's
READOUTS = ("walk", "steps", "accept", "runs", "paths")
AUTHORS_READOUTS = ("paths", "walk")  # what the authors' encoder reads out
WALK_STARTS = ("initial", "node1")
DISTANCES = ("squared", "euclidean")  # the triplet loss's distance (embed/triplets.py)


def widths_of(text: str) -> tuple[int, ...]:
    """Layer widths as written on the command line ("2048,512,256,200" or "2048, 512, 256, 200")."""
    try:
        widths = tuple(int(x) for x in text.replace(",", " ").split())
    except ValueError:
        widths = ()
    if not widths or min(widths) < 1:
        raise SettingError("widths", f"takes positive widths like 2048,512,256,200, not '{text}'")
    return widths


RUN_READOUTS = ("accept", "runs")  # the readouts of `automaton.accepted_run_weights`
SETTINGS_VERSION = 2  # config.json's "settings_version"; `settings_from_config` reads older ones
AUTO_MONITORS = 10  # monitors=None: the most atoms of a training formula, at most this many


# the authors' q (clear-nus/T-LEAF src/Synthetic: meta_embedder_train.py's
# Node_only_random_agg_min_clip, TripletMarginLoss(margin=1, p=2), Adam(lr=0.01,
# weight_decay=5e-4), a step every 256): presets paper-code and paper-text
AUTHORS_Q: dict[str, Any] = {
    "encoder": "authors",
    "directed": True,
    "readout": "paths",
    "steps": 4,
    "walk_from": "node1",
    "monitors": 0,
    "evidence": False,
    "sphere": True,
    "radius_weight": 0.0,
    "distance": "euclidean",
    "lr": 0.01,
    "weight_decay": 5e-4,
    "batch_size": 256,
    "schedule": "constant",
    "epochs": 200,
    "patience": None,
}


@dataclass(frozen=True)
class MetaSettings(Presets):
    """Every setting of q_m's training (saved as config.json's "settings").

    The field defaults are preset `best`, the q behind the Table I pipeline's figures;
    `MetaSettings.preset("paper")` is the 2021 paper's q. Fields that default to None are
    chosen from the data (`resolved`), and a saved config holds the chosen values.
    """

    embedder: str = setting(
        "dfa",
        "dfa (T-LEAF: the formula's automaton) or syntax (the paper's syntax-tree baseline).",
        choices=EMBEDDERS,
    )
    encoder: str = setting(
        "tleaf",
        "tleaf: --layers GCN layers of --hidden, a linear head to --out-dim after the readout; "
        "authors: the authors' code's GCN (layers of --widths, ReLU after every one, no head, "
        "the last width is the vector size; readout paths or walk, from --walk-from).",
        choices=ENCODERS,
    )
    widths: str = setting(
        "2048, 512, 256, 200",
        "--encoder authors: the GCN layers' widths, comma-separated; the last is the vector size.",
    )
    hidden: int = setting(100, "GCN width.", min=1)
    layers: int = setting(4, "GCN layers.", min=1)
    out_dim: int = setting(200, "Size of the learned part of q's vectors.", min=1)
    directed: bool = setting(
        True,
        "Messages along and against the arcs through separate weights (off: the paper's "
        "GCN over arcs taken both ways). With --encoder authors: messages along the arcs "
        "only, as in the authors' directed graph (off: arcs taken both ways).",
    )
    readout: str = setting(
        "runs",
        "walk: expected visits of a random walk from the initial state (the paper); "
        "steps: one projection per walk step; accept: where accepted runs of 1..--max-length "
        "letters go; runs: accepted and rejected runs, each with their own projections; "
        "paths (--encoder authors): the mean node state over --paths random paths of at "
        "most --steps + 1 nodes, drawn while training, their expectation otherwise.",
        choices=READOUTS,
    )
    steps: int = setting(24, "walk/steps/paths readouts: random-walk steps.", min=1)
    paths: int = setting(10, "paths readout: random paths per graph.", min=1)
    walk_from: str = setting(
        "initial",
        "--encoder authors: where walks and paths start: the initial state (the paper's "
        "text), or node index 1 (the authors' code: state 1; a trace's second state).",
        choices=WALK_STARTS,
    )
    dead_state: bool = setting(
        True,
        "--encoder authors: keep a DFA's dead state (the rejecting sink no accepted word "
        "passes) and the edges into it in q's graph; off: the trimmed automaton, as the "
        "authors' spot prints it (node 1 then counts the live states only).",
    )
    bins: int = setting(
        5, "accept/runs readouts: a run is cut in this many parts, one projection each.", min=1
    )
    max_length: int = setting(
        12,
        "accept/runs readouts and monitors: the longest run of a DFA counted (a trace is "
        "read whole).",
        min=1,
    )
    monitors: int | None = setting(
        None,
        "Fixed temporal monitors (F p, G p, p U q, G(p -> X q), ...) over the first "
        "this-many atoms of each formula: a formula gets the share of its accepted (and "
        "rejected) words each monitor accepts, a trace whether each accepts it; 0: none.",
        min=0,
        auto=f"auto: the most atoms of a training formula, at most {AUTO_MONITORS}; 0 for the "
        "syntax embedder",
    )
    monitor_ranges: int = setting(
        3,
        "--monitors: ranges of word length kept apart (a formula's shares per range, a "
        "trace in its own length's range).",
        min=1,
    )
    evidence: bool | None = setting(
        None,
        "Append the monitors' naive-Bayes block to every vector: a block whose squared "
        "distance falls as the naive-Bayes score for 'satisfies' rises (needs --monitors and "
        "--readout runs).",
        auto="auto: on with monitors and the runs readout",
    )
    evidence_scale: float = setting(
        256.0, "--evidence: the block's squared scale γ² at the start (learned after).", min=1e-6
    )
    sphere: bool | None = setting(
        None,
        "Scale the learned part of every vector to unit length (with --evidence the "
        "block keeps its scale γ).",
        auto="auto: on with --evidence",
    )
    probes: int = setting(
        0,
        "accept/runs readouts: this many learned 4-state probe automata read along the runs "
        "(0: none).",
        min=0,
    )
    radius_weight: float = setting(
        1.0,
        "Weight of a loss fitting one radius r for all formulas (satisfying traces within "
        "r, violating beyond: the distance rule the tleaf loss reads); 0: the triplet loss "
        "alone.",
        min=0.0,
    )
    pull: float = setting(
        0.0, "Weight of the mean d(formula, satisfying trace) added to the loss; 0: none.", min=0.0
    )
    margin: float = setting(1.0, "Triplet loss margin.")
    distance: str = setting(
        "squared",
        "The triplet loss's distance: squared Euclidean, or Euclidean (the authors' code: "
        "torch's triplet margin loss with p = 2).",
        choices=DISTANCES,
    )
    lr: float = setting(1e-3, "Adam learning rate.")
    weight_decay: float = setting(0.0, "Adam weight decay (L2 on the weights).", min=0.0)
    schedule: str = setting(
        "cosine",
        "Learning rate: constant, or cosine (falls to 0 over --epochs).",
        choices=SCHEDULES,
    )
    batch_size: int = setting(64, "Triplets per batch.", min=1)
    epochs: int = setting(6, "Most epochs to train.", min=1)
    patience: int | None = setting(
        None,
        "Stop after this many epochs without a better val score.",
        min=1,
        auto="none: no early stop",
    )
    seed: int = setting(0, "Random seed; the same seed writes the same model.")
    device: str = setting("cpu", "Where to compute.", choices=DEVICES)
    max_minutes: float | None = setting(
        None, "Stop after the epoch that passes this budget.", auto="none"
    )

    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {
        "best": {},
        "paper": {
            "directed": False,
            "readout": "walk",
            "bins": 1,
            "monitors": 0,
            "evidence": False,
            "sphere": False,
            "radius_weight": 0.0,
            "schedule": "constant",
            "epochs": 30,
            "patience": 5,
        },
        "paper-code": AUTHORS_Q,
        # the paper's text: "random walks from the initial state"
        "paper-text": {**AUTHORS_Q, "walk_from": "initial"},
    }
    PRESET_HELP: ClassVar[dict[str, str]] = {
        "best": "the Table I pipeline's q: directed messages, the runs readout in 5 parts, "
        "temporal monitors and their naive-Bayes evidence, one radius, cosine schedule, 6 epochs",
        "paper": "tleaf's reading of the 2021 paper's q (its Table I rows on tleaf's tiers): GCN "
        "over arcs taken both ways, walk readout, triplet loss alone, constant learning rate, "
        "30 epochs, early stop after 5",
        "paper-code": "the authors' code's q: GCN 2048-512-256-200 along the arcs, ReLU after "
        "every layer, mean over 10 random paths of 5 nodes from node 1, unit vectors, "
        "Euclidean triplet loss, Adam 0.01 with weight decay 5e-4, 256 triplets a step, 200 "
        "epochs",
        "paper-text": "paper-code with the walks from the initial state, as the paper's text says",
    }

    def preset_name(self) -> str:
        """The preset these settings are (`custom` if none): the first whose values they have,
        an automatic (None) value matching any choice, the length of training not compared."""
        defaults = {f.name: default_of(f) for f in fields(self)}
        for name, values in self.PRESETS.items():
            want = {**defaults, **values}
            if all(
                want[k] is None or want[k] == getattr(self, k)
                for k in PRESET_FIELDS
                if k not in LOOP_FIELDS
            ):
                return name
        return "custom"

    def resolved(self, max_atoms: int) -> MetaSettings:
        """These settings with every automatic (None) choice made for training formulas of at
        most `max_atoms` atoms; SettingError where the choices do not fit together."""
        check_values(self)
        monitors = self.monitors
        if monitors is None:
            tleaf_dfa = self.embedder == "dfa" and self.encoder == "tleaf"
            monitors = min(max_atoms, AUTO_MONITORS) if tleaf_dfa else 0
        evidence = self.evidence
        if evidence is None:
            evidence = monitors > 0 and self.readout == "runs" and self.embedder == "dfa"
        sphere = evidence if self.sphere is None else self.sphere
        out = replace(self, monitors=monitors, evidence=evidence, sphere=sphere)
        out.check()
        return out

    def check(self) -> None:
        """SettingError where resolved settings do not fit together."""
        check_values(self)
        if self.monitors and self.embedder != "dfa":
            raise SettingError("monitors", "only with the dfa embedder (monitors read DFAs)")
        if self.evidence and not (self.monitors and self.readout == "runs"):
            raise SettingError(
                "evidence", "needs monitors and the runs readout (it reads rejected words' shares)"
            )
        if self.probes and self.readout not in RUN_READOUTS:
            raise SettingError("probes", f"need an accept/runs readout, not {self.readout!r}")
        widths_of(self.widths)
        authors = self.encoder == "authors"
        if authors and self.readout not in AUTHORS_READOUTS:
            raise SettingError(
                "readout", f"the authors' encoder reads out paths or walk, not {self.readout!r}"
            )
        if not authors and self.readout == "paths":
            raise SettingError("readout", "paths is the authors' readout: encoder authors")
        if authors and (self.monitors or self.probes or self.embedder != "dfa"):
            raise SettingError(
                "encoder", "authors: the dfa embedder without monitors, evidence or probes"
            )


def recommended_lambda(figures: dict) -> float:
    """The tleaf loss's λ that fits a q: 1 / b, b its satisfy/violate boundary, the midpoint of
    its mean squared distance from a formula to its satisfying and to its violating traces
    (`figures`: a metrics.json split's). λ · d(q(A_φ), q(w̃)) is then about 1 at q's boundary,
    whatever q's scale: the evidence q's distances lie about 2γ² ≈ 500 (λ ≈ 0.002), a q without
    the block's about 1-10."""
    boundary = 0.5 * (figures["satisfying_distance"] + figures["violating_distance"])
    return 1.0 / max(boundary, 1e-6)


# Settings of version 1 (config.json without "settings_version"): the fields then, with their
# defaults then (a config lacking a field was written before the field existed), and the value
# of each field since removed at which it changed nothing.
LEGACY_DEFAULTS: dict[str, Any] = {
    **{f.name: default_of(f) for f in fields(MetaSettings)},
    **MetaSettings.PRESETS["paper"],
    "evidence_scale": 32.0,
    "monitor_ranges": 1,
}
REMOVED_NEUTRAL: dict[str, Any] = {
    "length_ranges": 1,
    "anchors": 0,
    "probe_states": 4,
    "probe_mix": 0,
    "conv": "gcn",
    "head": "linear",
    "jumping": False,
    "residual": False,
    "norm": False,
    "pair_weight": 0.0,
}


def settings_from_config(config: dict, where: str | Path) -> MetaSettings:
    """The settings a model folder's config.json records, migrated from older versions: a
    version-1 config gets the defaults of its time for fields it lacks, and loads where every
    setting since removed has the value that changed nothing (InputError naming the setting
    otherwise: that q cannot be rebuilt)."""
    version = config.get("settings_version", 1)
    if version > SETTINGS_VERSION:
        raise InputError(
            f"{where}: settings version {version} is newer than this tleaf's "
            f"({SETTINGS_VERSION}); upgrade tleaf"
        )
    saved = dict(config["settings"])
    if version == 1:
        for name, neutral in REMOVED_NEUTRAL.items():
            value = saved.pop(name, neutral)
            if name == "probe_states" and not saved.get("probes"):
                continue
            if value != neutral:
                raise InputError(
                    f"{where}: this q was trained with {name} = {value!r}, which tleaf no "
                    "longer builds; train it again"
                )
        saved = {**LEGACY_DEFAULTS, **saved}
    return MetaSettings(**saved)


# the fields a preset sets: what tells one preset's q from another's (but how long and how
# fast it trains: `LOOP_FIELDS`)
LOOP_FIELDS = ("epochs", "patience", "lr", "batch_size", "weight_decay")
PRESET_FIELDS = sorted({k for values in MetaSettings.PRESETS.values() for k in values})
