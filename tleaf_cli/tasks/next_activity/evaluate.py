"""Scoring a next-activity run on the test split (`tleaf eval next-activity`; the validation
split with `split="val"`, to choose settings there).

- **Next-activity accuracy**, pooled over every prefix of length ≥ 1 of the test cases, the end
  of case a target (Rama-Maneiro et al.'s protocol; train.accuracy).
- **Suffix prediction** from the prefixes of the given lengths k (every test case with at least
  k activities; Tax et al.'s and Di Francescomarino et al.'s protocol), several ways:
  `argmax` (the most probable next activity at each step, Tax et al.'s), `beam` (beam search,
  no rules), with `mbr_samples` `mbr` (minimum Bayes risk: suffix_mbr.py) and, with rules,
  `rules` (the most probable continuation whose completed case satisfies them, searched in the
  product of the model and the rules' DFA:
  suffix_search.py). Each: the mean Damerau-Levenshtein similarity of the predicted and the
  true suffix (similarity.py; and Mezini et al.'s over the whole trace with an end symbol,
  `trace_dl_similarity`), the share of predicted cases that satisfy the rules, and
  milliseconds per case; `suffix_pooled`: the same over every scored prefix of every length
  (Rama-Maneiro et al.'s and Tax et al.'s mean over all (case, prefix) pairs).

With `scored="satisfying"`, only the test cases that satisfy the rules are scored (Di
Francescomarino et al. evaluate on the cases whose outcome their formula describes).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict
from functools import partial
from pathlib import Path

import numpy as np
import torch

from tleaf_cli.data.artifacts import (
    check_writable,
    describe_inputs,
    file_sha256,
    write_text_atomic,
)
from tleaf_cli.data.event_logs import Case, Cases, read_cases
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.settings.next_activity import NextActivitySettings, SuffixSettings, prefix_lengths
from tleaf_cli.tasks.next_activity.encoding import Encoder
from tleaf_cli.tasks.next_activity.joint_tokens import (
    JointRules,
    JointTokens,
    joint_log_probs,
    joint_rules,
)
from tleaf_cli.tasks.next_activity.model import NextActivityModel
from tleaf_cli.tasks.next_activity.prefix_table import seen_in_training
from tleaf_cli.tasks.next_activity.rule_automaton import rule_automaton
from tleaf_cli.tasks.next_activity.rules import Rules, read_rules
from tleaf_cli.tasks.next_activity.similarity import (
    dl_similarity,
    jaccard_similarity,
    trace_dl_similarity,
)
from tleaf_cli.tasks.next_activity.suffix_mbr import mbr_suffixes
from tleaf_cli.tasks.next_activity.suffix_sampling import sample_suffixes
from tleaf_cli.tasks.next_activity.suffix_search import SearchStats, predict_suffixes
from tleaf_cli.tasks.next_activity.train import accuracy, attribute_accuracy, new_model
from tleaf_cli.training.run_folder import read_run_config, recorded_input


def load_run(run_dir: str | Path) -> tuple[NextActivityModel, Encoder, NextActivitySettings]:
    """A train-task next-activity folder's best model (eval mode, CPU), encoder and settings;
    InputError naming the file when the folder is not such a run."""
    model, encoder, settings, _ = _load_run(run_dir)
    return model, encoder, settings


def _load_run(
    run_dir: str | Path,
) -> tuple[NextActivityModel, Encoder, NextActivitySettings, dict]:
    """`load_run`'s model, encoder and settings, and the run's config.json."""
    run_dir = Path(run_dir)
    weights_path = run_dir / "weights.pt"
    config = read_run_config(run_dir, "next-activity")
    if not weights_path.is_file():
        raise InputError(f"{weights_path}: missing (not a finished next-activity run)")
    try:
        encoder = Encoder.from_dict(config["encoder"])
        settings = NextActivitySettings(**config["settings"])
    except (ValueError, KeyError, TypeError) as e:
        raise InputError(
            f"{run_dir / 'config.json'}: not a next-activity run's config ({e})"
        ) from None
    model = new_model(encoder, settings, _train_sequences(run_dir, config, encoder, settings))
    try:
        model.load_state_dict(torch.load(weights_path, map_location="cpu", weights_only=True))
    except (RuntimeError, OSError, EOFError, ValueError) as e:
        first = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise InputError(f"{weights_path}: not this run's model's weights ({first})") from None
    return model.eval(), encoder, settings, config


def _train_sequences(
    run_dir: str | Path, config: dict, encoder: Encoder, settings: NextActivitySettings
) -> list:
    """The run's training cases as activity indices, for a model counted from them (the prefix
    table); none for the others."""
    if settings.model != "prefix-table":
        return []
    return train_sequences(recorded_input(run_dir, config, "data"), encoder)


def train_sequences(cases_path: str | Path, encoder: Encoder) -> list:
    """The train split of a cases artifact as activity-index arrays."""
    return [encoder.indices(c) for c in read_cases(cases_path).cases if c.split == "train"]


def check_same_log(cases: Cases, encoder: Encoder, run_dir: str | Path) -> None:
    """InputError where `cases` name the run's activity atoms otherwise than the run did (another
    preprocessing of the log: its atom a3 another activity), which would score the model's
    predictions against other activities."""
    theirs = {atom: activity for activity, atom in cases.activity_atoms.items()}
    ours = dict(zip(encoder.atoms, encoder.activities, strict=True))
    clash = [a for a in ours if a in theirs and theirs[a] != ours[a]]
    if clash:
        a = clash[0]
        raise InputError(
            f"{cases.path}: its {a} is {theirs[a]!r}, the run's {a} was {ours[a]!r} "
            f"({len(clash)} activities differ): another preprocessing of the log than {run_dir} "
            "was trained on; evaluate on the cases artifact the run was trained on"
        )


def compare_with_training(cases: Cases, trained: Path | None, run_dir: str | Path) -> list[str]:
    """What makes scoring `cases` on the run doubtful, as warnings; InputError where they are
    another preprocessing of the log the run trained on (`trained`): a case of both has other
    activities in one than in the other (activity ids numbered otherwise), so the run's
    predictions would be scored against other activities."""
    if trained is None or file_sha256(trained) == file_sha256(cases.path):
        return []
    ours = {c.case_id: c for c in read_cases(trained).cases}
    shared = [c for c in cases.cases if c.case_id in ours]
    changed = [c for c in shared if c.activities != ours[c.case_id].activities]
    if changed:
        raise InputError(
            f"{cases.path}: case {changed[0].case_id} (and {len(changed) - 1} more of "
            f"{len(shared)} shared) has other activities than in {trained}, which {run_dir} "
            "was trained on: another preprocessing of the log; evaluate on the cases the run "
            "was trained on"
        )
    seen = [c for c in shared if c.split == "test" and ours[c.case_id].split != "test"]
    out = [f"{cases.path} is not the file {run_dir} was trained on ({trained})"]
    if seen:
        out.append(
            f"{len(seen)} of its test cases were training or validation cases of the run (another "
            "split of the log): its figures are not test figures"
        )
    return out


def evaluate_next_activity(
    run_dir: str | Path,
    cases_path: str | Path,
    out_dir: str | Path,
    settings: SuffixSettings,
    rules_path: str | Path | None = None,
    rule_names: Sequence[str] = (),
    on_length: Callable[[int, int], None] | None = None,
    scored_by: str | Path | None = None,
    scored_by_names: Sequence[str] = (),
) -> dict:
    """Score the run on the test split of `cases_path`; write and return metrics.json.

    The rules of the suffix search and of next-activity prediction under the rules
    (`accuracy_rules`) are the knowledge base the run trained with, read from its config.json
    (checked to be the same bytes), unless `rules_path` names other rules; `rule_names`: only
    these of them. `scored_by` / `scored_by_names`: the rules that choose the scored cases
    with `scored="satisfying"` (default: the same rules). `on_length(done, total)` hears each
    prefix length finished. Cases that are another preprocessing of the log the run trained on
    are refused (`compare_with_training`); metrics.json's "warnings" says what makes the
    figures doubtful: the cases are not the file the run trained on, test cases the run
    trained on."""
    settings.check()
    out_dir = Path(out_dir)
    check_writable(out_dir / "metrics.json")
    model, encoder, _, config = _load_run(run_dir)
    try:
        own = recorded_input(run_dir, config, "kb")
    except InputError:
        if rules_path is None:
            raise
        own = None  # other rules given: the run's may be gone
    same = rules_path is None or (own is not None and file_sha256(rules_path) == file_sha256(own))
    source = "run" if same else "other"  # --rules naming the run's own file is the run's rules
    if rules_path is None:
        rules_path = own
    if rules_path is None and rule_names:
        raise SettingError("rule_names", f"{run_dir} trained without rules: name other rules")
    if rules_path is None and settings.rule_weight is not None:
        raise SettingError(
            "rule_weight",
            f"weighs rules, and the run {run_dir} trained without any: name other rules",
        )
    if settings.scored == "satisfying" and rules_path is None and scored_by is None:
        raise SettingError("scored", "'satisfying' needs rules: which cases satisfy what?")
    device = torch.device("cpu")  # the run's model is loaded on the CPU (load_run)
    cases = read_cases(cases_path)
    check_same_log(cases, encoder, run_dir)
    warnings = compare_with_training(cases, recorded_input(run_dir, config, "data"), run_dir)
    test = [c for c in cases.cases if c.split == settings.split]
    if not test:
        raise InputError(f"{cases_path}: no cases in the {settings.split} split")
    strange = [c for c in test if not encoder.knows(c)]
    if strange:
        warnings.append(
            f"{len(strange)} test case(s) have activities the run never saw in training "
            f"(first: {strange[0].case_id}): left out of next-activity accuracy; suffix "
            "prediction scores them where the prefix is known"
        )
    joint = None  # with attributes: the suffixes are events (joint_tokens.py)
    if encoder.attributes and rules_path is not None:
        joint = joint_rules(rules_path, JointTokens(encoder), rule_names)
        if joint.unseen:
            warnings.append(
                f"the rules name {len(joint.unseen)} atom(s) no event of the model can have "
                f"({', '.join(joint.unseen[:5])}): rules on them are not met by any prediction"
            )
    activity_rules = joint is None or joint.activities_only
    rules = None
    if rules_path is not None and activity_rules:
        rules = read_rules(rules_path, encoder.atoms, rule_names, log_atoms=encoder.names())
    elif settings.scored == "satisfying" and scored_by is None:
        raise SettingError("scored", "'satisfying' reads rules on activities only")
    if rules is not None and rules.unseen:
        named = sorted({a for missing in rules.unseen.values() for a in missing})
        warnings.append(
            f"{len(rules.unseen)} rule(s) name activities the model does not know "
            f"({', '.join(named[:5])}), read as never happening: {', '.join(rules.unseen)}"
        )
    scored = test
    judge = rules
    if scored_by is not None:
        judge = read_rules(scored_by, encoder.atoms, scored_by_names, log_atoms=encoder.names())
    if settings.scored == "satisfying":
        keep = ~judge.broken([encoder.indices(c) for c in test])
        scored = [c for c, k in zip(test, keep, strict=True) if k]
        if not scored:
            raise InputError(f"{cases_path}: no test case satisfies the rules of {judge.path}")
    known = [c for c in scored if encoder.knows(c)]
    if not known:
        raise InputError(no_known_case(cases_path, scored, encoder, run_dir))
    metrics: dict = {
        "task": "next-activity",
        "run": str(run_dir),
        "split": settings.split,
        "test_cases": len(test),
        "scored_cases": len(scored),
        "rules": None
        if rules is None and joint is None
        else {
            "path": (rules or joint).path,
            "names": list((rules or joint).names),
            "source": source,
            "attributes": not activity_rules,
        },
        "scored_by": None if judge is None else {"path": judge.path, "names": list(judge.names)},
        "settings": asdict(settings),
        "accuracy": accuracy(
            model,
            encoder,
            known,
            256,
            device,
            rules,
            seen=leakage(run_dir, config, encoder, known),
        )
        | attribute_accuracy(model, encoder, known, 256, device),
        "suffix": {},
        "warnings": warnings,
        "inputs": describe_inputs([p for p in (cases_path, rules_path) if p is not None]),
    }
    if settings.prefix_lengths is not None:
        lengths = prefix_lengths(settings.prefix_lengths)
        for done, k in enumerate(lengths, start=1):
            metrics["suffix"][str(k)] = suffix_scores(
                model, encoder, scored, k, settings, rules, joint
            )
            if on_length is not None:
                on_length(done, len(lengths))
        metrics["suffix_pooled"] = pooled(metrics["suffix"])
    write_text_atomic(out_dir / "metrics.json", json.dumps(metrics, indent=2))
    return metrics


def no_known_case(
    cases_path: str | Path, scored: Sequence[Case], encoder: Encoder, run_dir: str | Path
) -> str:
    """Why nothing can be scored when every scored test case has an activity the run never saw
    in training (another log, or another preprocessing of it): the next-activity accuracy would
    be over no prefix at all."""
    known = set(encoder.atoms)
    pairs = {(name, atom) for c in scored for name, atom in zip(c.activities, c.atoms, strict=True)}
    unknown = sorted(name for name, atom in pairs if atom not in known)
    return (
        f"{cases_path}: none of its {len(scored)} scored test case(s) has only activities "
        f"the run {run_dir} knows ({len(unknown)} it never saw in training, such as "
        f"{', '.join(map(repr, unknown[:3]))}): nothing to score; evaluate on cases of the log "
        "the run was trained on"
    )


def leakage(
    run_dir: str | Path, config: dict, encoder: Encoder, scored: Sequence[Case]
) -> np.ndarray | None:
    """Per scored prefix, whether the same prefix with the same next token occurs in the run's
    training cases (`prefix_table.seen_in_training`); None where the run's cases are gone."""
    try:
        trained = recorded_input(run_dir, config, "data")
    except InputError:
        return None
    if trained is None:
        return None
    train = train_sequences(trained, encoder)
    return seen_in_training(train, [encoder.indices(c) for c in scored], encoder.end)


def suffix_scores(
    model: NextActivityModel,
    encoder: Encoder,
    cases: Sequence[Case],
    k: int,
    settings: SuffixSettings,
    rules: Rules | None,
    joint: JointRules | None = None,
) -> dict:
    """Suffix prediction from the k-prefixes of the cases with at least `settings.min_suffix`
    more activities: per way (argmax, beam, with a temperature sample; under rules each again
    with the rules a hard filter: argmax_rules, rules (the beam), sample_rules; with a rule
    weight, each again with the rules a soft score: argmax_soft, beam_soft, sample_soft), the
    mean DL similarity (of the suffix, and Mezini et al.'s of the whole trace), Jaccard
    similarity, the share satisfying the rules, ms per case, and the share of predicted suffixes
    that stop at the length cap (`at_cap`: a search that loops until `max_suffix`) beside the
    share of true suffixes that long (`true_at_cap`, once); with attributes, DL and Jaccard
    similarity of each attribute's values too.

    With event attributes (`encoder.attributes`) the search runs over events, each an activity
    and its values (joint_tokens.py), under `joint`: rules that may name attribute values."""
    chosen = [c for c in cases if len(c) >= k + settings.min_suffix]
    space = JointTokens(encoder)  # activities, or events with their attributes' values
    v, split = space.size, space.decode
    # an activity the model does not know: a true suffix may have it (no prediction matches
    # it), a prefix the model reads may not
    sequences = [space.of_case(c) for c in chosen]
    readable = [bool((s[:k] >= 0).all()) for s in sequences]
    unreadable = len(chosen) - sum(readable)
    chosen = [c for c, r in zip(chosen, readable, strict=True) if r]
    sequences = [s for s, r in zip(sequences, readable, strict=True) if r]
    if not chosen:
        return {"cases": 0, "unknown_prefixes": unreadable}
    step = joint_log_probs(
        model,
        encoder,
        space,
        [c.timestamps[:k] for c in chosen],
        [encoder.input_columns(c)[:k] for c in chosen],
    )
    if encoder.attributes:
        automaton = None if joint is None else joint.automaton
        search_rules = automaton
    else:
        search_rules = None if rules is None else rules.parts
        automaton = rule_automaton(search_rules, v)
    prefixes = [tuple(a[:k].tolist()) for a in sequences]
    truth = [tuple(a[k:].tolist()) for a in sequences]
    searches = {
        "argmax": partial(predict_suffixes, beam_width=1),
        "beam": partial(predict_suffixes, beam_width=settings.beam_width),
    }
    if settings.temperature is not None:
        searches["sample"] = partial(sample_suffixes, temperature=settings.temperature)
    if settings.mbr_samples is not None:
        searches["mbr"] = partial(
            mbr_suffixes, samples=settings.mbr_samples, compared=lambda t: split(t)[0]
        )
    ways = {way: (search, None) for way, search in searches.items()}
    if automaton is not None:  # each way again, the rules a hard filter
        ways.update({f"{way}_rules": (s, search_rules) for way, s in searches.items()})
        ways["rules"] = ways.pop("beam_rules")  # the beam search under the rules: its old name
        if settings.rule_weight is not None:  # and as a soft score
            for way in searches:
                soft = partial(searches[way], rule_weight=settings.rule_weight)
                ways[f"{way}_soft"] = (soft, search_rules)
    out: dict = {
        "cases": len(chosen),
        "unknown_prefixes": unreadable,
        "true_at_cap": _mean(len(t) >= settings.max_suffix for t in truth),
    }
    true_parts = [split(t) for t in truth]
    for way, (search, parts) in ways.items():
        stats = SearchStats()
        start = time.perf_counter()
        found = search(step, prefixes, v, rules=parts, max_length=settings.max_suffix, stats=stats)
        seconds = time.perf_counter() - start
        parts_found = [split(f.activities) for f in found]
        pairs = list(zip(parts_found, true_parts, strict=True))
        activity_prefixes = [split(p)[0] for p in prefixes]
        out[way] = {
            "dl_similarity": _mean(dl_similarity(f[0], t[0]) for f, t in pairs),
            "trace_dl_similarity": _mean(
                trace_dl_similarity(p, f[0], t[0])
                for p, (f, t) in zip(activity_prefixes, pairs, strict=True)
            ),
            "jaccard": _mean(jaccard_similarity(f[0], t[0]) for f, t in pairs),
            "ms_per_case": 1000 * seconds / len(chosen),
            "model_calls": stats.model_calls,
            "at_cap": _mean(len(f.activities) >= settings.max_suffix for f in found),
        }
        for a, name in enumerate(encoder.attributes):
            out[way][f"dl_similarity_{name}"] = _mean(
                dl_similarity(f[1][:, a], t[1][:, a]) for f, t in pairs
            )
            out[way][f"jaccard_{name}"] = _mean(
                jaccard_similarity(f[1][:, a], t[1][:, a]) for f, t in pairs
            )
        if automaton is not None:
            kept = [
                automaton.accepts(p + f.activities) for p, f in zip(prefixes, found, strict=True)
            ]
            out[way]["satisfying"] = float(np.mean(kept))
        if parts is not None and not way.endswith("_soft"):
            out[way]["not_found"] = stats.fallbacks
    return out


def _mean(values) -> float:
    return float(np.mean(list(values)))


POOLED = ("dl_similarity", "trace_dl_similarity", "jaccard", "at_cap", "satisfying")


def pooled(by_length: dict) -> dict:
    """The suffix figures over every scored prefix of every length, each length weighted by
    its prefixes (Rama-Maneiro et al.'s and Tax et al.'s "mean DL" over all (case, prefix)
    rows): per way, the pooled means of `POOLED` it has, and `prefixes`, `true_at_cap`."""
    rows = [r for r in by_length.values() if r.get("cases")]
    if not rows:
        return {}
    weights = np.array([r["cases"] for r in rows], dtype=np.float64)
    out: dict = {
        "prefixes": int(weights.sum()),
        "true_at_cap": float(np.average([r["true_at_cap"] for r in rows], weights=weights)),
    }
    ways = [w for w, figures in rows[0].items() if isinstance(figures, dict)]
    for way in ways:
        out[way] = {
            name: float(np.average([r[way][name] for r in rows], weights=weights))
            for name in POOLED
            if name in rows[0][way]
        }
    return out
