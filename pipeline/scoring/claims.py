"""The claims of a verdict, and how two verdicts' claims compare (issue 57, item 2; issue 56, item 6).

Claims (this module's :func:`claims`): per held-out case, metric and pair of models, ``a_better``, ``b_better``
or ``cannot_tell_apart`` as ``model_differences.csv`` states them; a pair where exactly one model's
score is infinite (it predicts no creep where the DEM creeps: the verdict's ``worse``) counts as
told apart, the finite one better. A variant's claim against the full root's (:func:`compare_claims`):
**confirmed** (told apart the same way), **lost** (the full root told them apart, the variant cannot,
or cannot score the pair: ``unscored`` counts these), **contradicted** (told apart the other way),
**new** (told apart where the full root cannot); ``still_cannot_tell_apart`` the rest. Only
(case, metric) pairs the full root's table holds are compared.

Read by :mod:`pipeline.scoring.claims_cost` (the verdict against less DEM),
:mod:`pipeline.scoring.claims_across_roots` (against another root) and ``benchmarks/verdict_stability.py``.
"""
from __future__ import annotations

import itertools
import math

import pandas as pd

#: A variant's claim against the full root's.
STATUSES = ("confirmed", "lost", "contradicted", "new", "still_cannot_tell_apart")
TOLD_APART = ("a_better", "b_better")

Key = tuple[str, str, str, str]  # case, metric, model_a, model_b (model_a < model_b)


# ----------------------------------------------------------------------------------- claims
def _flip(claim: str) -> str:
    return {"a_better": "b_better", "b_better": "a_better"}.get(claim, claim)


def _put(out: dict[Key, str], case: str, metric: str, a: str, b: str, claim: str) -> None:
    if a > b:
        a, b, claim = b, a, _flip(claim)
    out[(case, metric, a, b)] = claim


def claims(differences: pd.DataFrame, verdicts: pd.DataFrame | None = None) -> dict[Key, str]:
    """(case, metric, model_a, model_b) -> claim, model_a before model_b alphabetically (the pair's
    claim turned with it). With ``verdicts`` (``verdict.csv``'s rows), also the pairs
    ``model_differences.csv`` leaves out because a score is infinite: one infinite score, the finite
    model better; both infinite, ``cannot_tell_apart``."""
    out: dict[Key, str] = {}
    for r in differences.itertuples(index=False):
        _put(out, r.case, r.metric, r.model_a, r.model_b, r.claim)
    if verdicts is not None and not verdicts.empty:
        values = pd.to_numeric(verdicts["value"], errors="coerce")
        scored = verdicts[values.notna() & (verdicts["verdict"] != "no_prediction")].assign(score=values)
        for (case, metric), frame in scored.groupby(["case", "metric"], sort=True):
            rows = dict(zip(frame["model"], frame["score"].astype(float)))
            for a, b in itertools.combinations(sorted(rows), 2):
                ia, ib = math.isinf(rows[a]), math.isinf(rows[b])
                if not (ia or ib) or (case, metric, a, b) in out:
                    continue
                _put(out, case, metric, a, b, "cannot_tell_apart" if ia and ib else ("b_better" if ia else "a_better"))
    return out


def compare_claims(full: dict[Key, str], variant: dict[Key, str]) -> dict[Key, tuple[str, str | None, bool]]:
    """Key -> (status, the variant's claim or None, unscored) for every pair of a (case, metric) the
    full root judged (module docstring). A pair the full root did not score is taken as
    ``cannot_tell_apart`` there; one the variant does not score as not told apart."""
    judged = {(k[0], k[1]) for k in full}
    out = {}
    for key in sorted(set(full) | {k for k in variant if (k[0], k[1]) in judged}):
        f = full.get(key, "cannot_tell_apart")
        v = variant.get(key)
        if f in TOLD_APART:
            status = "confirmed" if v == f else ("contradicted" if v in TOLD_APART else "lost")
        else:
            status = "new" if v in TOLD_APART else "still_cannot_tell_apart"
        out[key] = (status, v, v is None)
    return out


def count_claims(full: dict[Key, str], variant: dict[Key, str], case: str) -> dict[str, int]:
    """The counts of one case: each status, ``unscored``, ``pairs`` and ``claims_full`` (the pairs the
    full root tells apart)."""
    full_case = {k: v for k, v in full.items() if k[0] == case}
    compared = compare_claims(full_case, {k: v for k, v in variant.items() if k[0] == case})
    counts = {s: 0 for s in STATUSES}
    for status, _, _ in compared.values():
        counts[status] += 1
    counts["unscored"] = sum(1 for status, _, missing in compared.values() if missing and status == "lost")
    counts["pairs"] = len(compared)
    counts["claims_full"] = sum(1 for v in full_case.values() if v in TOLD_APART)
    return counts
