"""How much room the knowledge base leaves on a SYNTHETIC activities file (docs/activities.md).

Per-step logistic regression (scikit-learn, fitted on train, scored on test) for actions and
for ingredients, then three decodings of its probabilities:
  plain          argmax of each classifier
  affordances    argmax over afforded pairs of p(a) p(i): what knowing the affordances adds
  true ingredient argmax over the actions the TRUE ingredient affords: the most affordances
                 could add with a perfect ingredient classifier

    python benchmarks/activities_baseline.py DIR...   (each DIR holds activities.parquet, kb.ltl)
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from sklearn.linear_model import LogisticRegression

from tleaf_cli.knowledge.base import read_knowledge_base
from tleaf_cli.tasks.action_recognition.activities import read_activities


def afforded(data, kb) -> np.ndarray:
    """bool [A, I]: the pair is not forbidden by an affordance rule."""
    allowed = np.ones((len(data.actions), len(data.ingredients)), dtype=bool)
    index = {data.atom(a, i): (a, i) for a in range(len(data.actions))
             for i in range(len(data.ingredients))}  # fmt: skip
    for rule in kb.of_kind("affordance"):
        allowed[index[rule.atoms[0]]] = False
    return allowed


def main(directory: Path) -> None:
    data = read_activities(directory / "activities.parquet")
    allowed = afforded(data, read_knowledge_base(directory / "kb.ltl"))
    split = {s: data.split(s) for s in ("train", "test")}
    x = {s: np.concatenate([v.features for v in vs]) for s, vs in split.items()}
    probs, truth = {}, {}
    for target in ("actions", "ingredients"):
        y = {s: np.concatenate([getattr(v, target) for v in vs]) for s, vs in split.items()}
        clf = LogisticRegression(max_iter=2000).fit(x["train"], y["train"])
        probs[target], truth[target] = clf.predict_proba(x["test"]), y["test"]
    pa, pi = probs["actions"], probs["ingredients"]
    ta, ti = truth["actions"], truth["ingredients"]
    unafforded = ~allowed[pa.argmax(1), pi.argmax(1)]
    joint = (pa[:, :, None] * pi[:, None, :] * allowed).reshape(len(pa), -1).argmax(1)
    da, di = np.divmod(joint, len(data.ingredients))
    true_ingredient = (pa * allowed[:, ti].T).argmax(1)
    print(
        f"{directory}: action {np.mean(pa.argmax(1) == ta):.1%}, ingredient "
        f"{np.mean(pi.argmax(1) == ti):.1%}, unafforded predicted pairs {unafforded.mean():.1%}; "
        f"with affordances: action {np.mean(da == ta):.1%}, ingredient {np.mean(di == ti):.1%}; "
        f"with the true ingredient: action {np.mean(true_ingredient == ta):.1%}"
    )


if __name__ == "__main__":
    for arg in sys.argv[1:]:
        main(Path(arg))
