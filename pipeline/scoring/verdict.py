"""Which models can be told apart: ``validation/verdict.csv``, ``model_differences.csv``, ``scene_needs.csv``.

For each held-out case and metric, every pair of models is compared by the difference of their
scores, ``D = S_a - S_b``, on the same points (the intruder's depths both cover), with an interval
from paired resampling: the same DEM resample and the same parameter draw enter both scores, so
what they share cancels (:mod:`pipeline.scoring.uncertainty`). Its variance is that of D over the
DEM resamples plus that over the draws plus both grids' ``u_num^2``; the interval is ``D +- k u``
with k Student's t at the config's confidence (0.95) for the Welch-Satterthwaite degrees of freedom.

Verdict per case, metric and model: ``best`` (lowest score), ``cannot_tell_apart`` (the interval of
its difference from the best holds 0), ``worse`` (it does not, or the model predicts no creep where
the DEM creeps: an infinite score), ``no_prediction`` (the model does not predict the quantity).

What each scene needs: per held-out case, walking :data:`continuum.complexity.ORDER` from the
simplest, the first model that is ``best`` or ``cannot_tell_apart`` on every creep and flow metric
of the case (:data:`SCENE_METRICS`); the next richer model and what it would add.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from continuum.complexity import MODEL_COMPLEXITY, ORDER
from pipeline.scoring.uncertainty import ScoreSamples, coverage_factor, welch_satterthwaite

#: The metrics a scene is judged on: how it creeps, and how it flows.
CREEP_METRICS = ("log_velocity_rmse", "decay_length_rel_err", "intruder_speed_log_err")
FLOW_METRICS = ("velocity_rmse_rel", "shear_band_width_rel_err", "intruder_bed_velocity_rmse", "intruder_field_velocity_rmse")
SCENE_METRICS = CREEP_METRICS + FLOW_METRICS

VERDICTS = ("best", "cannot_tell_apart", "worse", "no_prediction")
VERDICT_COLUMNS = ["case", "metric", "model", "value", "u_val", "verdict", "u_dem", "u_input", "u_num",
                   "difference_from_best", "u_difference", "ci_low", "ci_high", "dof", "points", "confidence"]
DIFFERENCE_COLUMNS = ["case", "metric", "model_a", "model_b", "value_a", "value_b", "difference", "u_difference",
                      "u_dem", "u_input", "u_num", "dof", "ci_low", "ci_high", "claim", "points", "confidence"]
SCENE_COLUMNS = ["case", "simplest_model", "next_model", "next_adds", "simplest_solve_ms", "next_solve_ms",
                 "metrics", "note"]


@dataclass(frozen=True)
class PairDifference:
    """``S_a - S_b`` with its uncertainty parts, degrees of freedom and interval."""

    difference: float
    u_dem: float
    u_input: float
    u_num: float
    dof: float
    low: float
    high: float

    @property
    def u(self) -> float:
        return math.sqrt(sum(x * x for x in (self.u_dem, self.u_input, self.u_num) if math.isfinite(x)))

    @property
    def claim(self) -> str:
        """``a_better``, ``b_better`` or ``cannot_tell_apart`` at the interval's confidence."""
        if self.high < 0.0:
            return "a_better"
        if self.low > 0.0:
            return "b_better"
        return "cannot_tell_apart"


def _paired_sd(a: np.ndarray, b: np.ndarray) -> tuple[float, int]:
    n = min(a.size, b.size)
    if n == 0:
        return math.nan, 0
    diff = a[:n] - b[:n]
    diff = diff[np.isfinite(diff)]
    return (float(diff.std(ddof=1)), int(diff.size)) if diff.size >= 2 else (math.nan, int(diff.size))


def compare(a: ScoreSamples, b: ScoreSamples, confidence: float) -> PairDifference:
    """The paired difference ``a - b`` of two finite scores (module docstring)."""
    u_param, _ = _paired_sd(np.asarray(a.dem), np.asarray(b.dem))
    u_offset, _ = _paired_sd(np.asarray(a.dem_offset), np.asarray(b.dem_offset))
    u_input, n_draws = _paired_sd(np.asarray(a.draws), np.asarray(b.draws))
    u_num = math.hypot(a.u_num if math.isfinite(a.u_num) else 0.0, b.u_num if math.isfinite(b.u_num) else 0.0)
    dof = welch_satterthwaite([(u_param, min(a.dem_dof, b.dem_dof)), (u_offset, min(a.offset_dof, b.offset_dof)),
                               (u_input, float(n_draws - 1)), (u_num, math.inf)])
    u_dem = math.sqrt(sum(x * x for x in (u_param, u_offset) if math.isfinite(x)))
    u = math.sqrt(sum(x * x for x in (u_dem, u_input, u_num) if math.isfinite(x)))
    k = coverage_factor(dof, confidence)
    d = a.value - b.value
    return PairDifference(d, u_dem, u_input, u_num, dof, d - k * u, d + k * u)


def shared_points(samples: dict[str, ScoreSamples]) -> list[str] | None:
    """The points every finite score covers, where scores carry per-point terms (the intruder); None
    where they do not (every model is scored on the same profile points)."""
    with_terms = [s for s in samples.values() if s.terms_value is not None]
    if not with_terms:
        return None
    covered = [set(p for p, t in zip(s.points, s.terms_value) if not np.isnan(t))
               for s in with_terms if np.isfinite(s.on_points(covered_points(s)).value)]
    if not covered:
        return []
    common = set.intersection(*covered)
    return [p for p in with_terms[0].points if p in common]


def covered_points(s: ScoreSamples) -> list[str]:
    """The points a per-point score covers (not refused: a finite or infinite term)."""
    return [p for p, t in zip(s.points, s.terms_value) if not np.isnan(t)]


@dataclass(frozen=True)
class Outcome:
    verdicts: pd.DataFrame
    differences: pd.DataFrame
    scene_needs: pd.DataFrame


def judge_metric(case: str, metric: str, models: list[str], samples: dict[str, ScoreSamples], confidence: float
                 ) -> tuple[list[dict], list[dict]]:
    """Verdict rows and pair rows of one held-out case and metric."""
    common = shared_points(samples)
    if common is None:
        on, points = dict(samples), next(iter(samples.values())).points[0]
    else:
        on = {}
        for m, s in samples.items():
            shared = s.on_points(common) if common else s.on_points(covered_points(s))
            # A model that cannot be scored on the shared points (it refuses one) keeps its own.
            on[m] = shared if not np.isnan(shared.value) else s.on_points(covered_points(s))
        points = " ".join(common)
    finite = {m: s for m, s in on.items() if math.isfinite(s.value)}
    best = min(finite, key=lambda m: finite[m].value) if finite else None
    rows = []
    for model in models:
        base = {"case": case, "metric": metric, "model": model, "points": points, "confidence": confidence}
        if model not in on:
            rows.append(base | {"value": math.nan, "u_val": math.nan, "verdict": "no_prediction"})
            continue
        s = on[model]
        row = base | {"value": s.value, "u_val": s.u_val if model in finite else math.nan,
                      "u_dem": s.u_dem if model in finite else math.nan,
                      "u_input": s.u_input if model in finite else math.nan,
                      "u_num": s.u_num if model in finite else math.nan}
        if best is None:
            rows.append(row | {"verdict": "no_prediction"})
        elif model == best:
            rows.append(row | {"verdict": "best", "difference_from_best": 0.0})
        elif model not in finite:
            rows.append(row | {"verdict": "worse", "difference_from_best": math.inf})
        else:
            pair = compare(s, finite[best], confidence)
            rows.append(row | {"verdict": "worse" if pair.low > 0.0 else "cannot_tell_apart",
                               "difference_from_best": pair.difference, "u_difference": pair.u,
                               "ci_low": pair.low, "ci_high": pair.high, "dof": pair.dof})
    pairs = []
    for a, b in itertools.combinations(sorted(finite), 2):
        pair = compare(finite[a], finite[b], confidence)
        pairs.append({"case": case, "metric": metric, "model_a": a, "model_b": b, "value_a": finite[a].value,
                      "value_b": finite[b].value, "difference": pair.difference, "u_difference": pair.u,
                      "u_dem": pair.u_dem, "u_input": pair.u_input, "u_num": pair.u_num, "dof": pair.dof,
                      "ci_low": pair.low, "ci_high": pair.high, "claim": pair.claim, "points": points,
                      "confidence": confidence})
    return rows, pairs


def judge(scores: pd.DataFrame, samples: dict[tuple[str, str, str], ScoreSamples], confidence: float,
          solve_costs: dict[tuple[str, str], float] | None = None) -> Outcome:
    """Verdicts, pair differences and scene needs of every held-out case (module docstring)."""
    held = scores[scores.role == "held_out"]
    verdict_rows, pair_rows = [], []
    for case, frame in held.groupby("case", sort=True):
        models = sorted(set(frame.model))
        for metric in sorted(set(frame.metric)):
            present = {m: samples[(case, m, metric)] for m in models if (case, m, metric) in samples}
            rows, pairs = judge_metric(case, metric, models, present, confidence)
            verdict_rows += rows
            pair_rows += pairs
    verdicts = pd.DataFrame(verdict_rows, columns=VERDICT_COLUMNS)
    return Outcome(verdicts, pd.DataFrame(pair_rows, columns=DIFFERENCE_COLUMNS),
                   scene_needs(verdicts, pd.DataFrame(pair_rows, columns=DIFFERENCE_COLUMNS), solve_costs or {}))


def solve_costs(scores: pd.DataFrame) -> dict[tuple[str, str], float]:
    """(case, model) -> solve time (s) of its nominal solution."""
    return {(c, m): float(t) for (c, m), t in scores.groupby(["case", "model"])["solve_seconds"].first().items()}


def scene_needs(verdicts: pd.DataFrame, differences: pd.DataFrame, costs: dict[tuple[str, str], float]) -> pd.DataFrame:
    """Per held-out case: the simplest adequate model, the next richer one and what it adds."""
    rows = []
    for case, frame in verdicts.groupby("case", sort=True):
        scene = frame[frame.metric.isin(SCENE_METRICS)]
        if scene.empty:
            continue
        metrics = sorted(set(scene.metric))
        solved = [m for m in ORDER if m in set(scene.model)]
        good = {m: set(scene[(scene.model == m) & scene.verdict.isin(("best", "cannot_tell_apart"))].metric)
                for m in solved}
        adequate = [m for m in solved if good[m] >= set(metrics)]
        note = ""
        if adequate:
            simplest = adequate[0]
        else:
            most = max(len(good[m]) for m in solved)
            simplest = next(m for m in solved if len(good[m]) == most)
            missing = sorted(set(metrics) - good[simplest])
            note = (f"no model is within the best set on every metric; {simplest} is on the most "
                    f"({most} of {len(metrics)}; not on {', '.join(missing)})")
        richer = solved[solved.index(simplest) + 1:]
        following = richer[0] if richer else ""
        adds = ""
        if following:
            parts = []
            for metric in metrics:
                row = differences[(differences.case == case) & (differences.metric == metric)
                                  & (((differences.model_a == following) & (differences.model_b == simplest))
                                     | ((differences.model_a == simplest) & (differences.model_b == following)))]
                if row.empty:
                    parts.append(f"{metric}: not compared (a score is infinite or missing)")
                    continue
                r = row.iloc[0]
                sign = 1.0 if r.model_a == following else -1.0
                change = sign * r.difference
                told = {"a_better": "better" if sign > 0 else "worse", "b_better": "worse" if sign > 0 else "better",
                        "cannot_tell_apart": "cannot tell apart"}[r.claim]
                parts.append(f"{metric} {change:+.3g} +- {r.ci_high - r.difference:.2g} ({told})")
            adds = f"{MODEL_COMPLEXITY[following].adds}. Its scores against {simplest}: " + "; ".join(parts)
        rows.append({"case": case, "simplest_model": simplest, "next_model": following or "none (the richest solved)",
                     "next_adds": adds, "simplest_solve_ms": 1e3 * costs.get((case, simplest), math.nan),
                     "next_solve_ms": 1e3 * costs.get((case, following), math.nan) if following else math.nan,
                     "metrics": " ".join(metrics), "note": note})
    return pd.DataFrame(rows, columns=SCENE_COLUMNS)
