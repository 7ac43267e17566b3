"""The verdict tells models apart at its stated confidence: synthetic replicas of known noise, two
models of known difference, through the same resampling and comparison the workflow runs."""
from __future__ import annotations

import functools
import math

import numpy as np
import pytest
import xarray as xr

from pipeline.scoring import metrics
from pipeline.scoring.uncertainty import (ScoreSamples, correlated_normal, dem_noise_model, offset_noise,
                                          offset_profiles, resample_profile, welch_satterthwaite)
from pipeline.scoring.verdict import compare, judge_metric, scene_needs

D = 0.002
N_POINTS = 60
Z = np.linspace(2 * D, 20 * D, N_POINTS)
TRUTH = 0.60 - 0.02 * (Z - Z[0]) / (Z[-1] - Z[0])
SIGMA = 0.003       # DEM noise of one replica at a point (nu)
TAU = 2.0           # its correlation along z (integrated autocorrelation time, points)
REPLICAS = 3
S_THETA = 0.0015    # the calibration's uncertainty of each model's parameter
SHAPE_A = np.ones(N_POINTS)
SHAPE_B = 1.0 + 0.8 * np.cos(np.pi * (Z - Z[0]) / (Z[-1] - Z[0]))
THETA_A = 0.01
#: Model B's offset lies above the truth, like A's (+1), or below it (-1: then a whole-profile offset
#: of the DEM moves the two scores apart instead of together).
B_SIDE = {"sign": 1.0}


def shape_b() -> np.ndarray:
    return B_SIDE["sign"] * SHAPE_B
DRAWS, RESAMPLES = 64, 200


def rmse(m: np.ndarray, dem: np.ndarray, err: np.ndarray) -> float:
    return metrics.rmse(m, dem)


def replica_noise(rng: np.random.Generator, offset_sd: float = 0.0) -> np.ndarray:
    """The replicas' departures from the truth, (replica, point): correlated pointwise noise of the
    stated errors, plus (``offset_sd``) a whole-profile offset per replica that no stated error
    holds (a packing realisation)."""
    return SIGMA * correlated_normal(rng, REPLICAS, N_POINTS, TAU) + offset_sd * rng.standard_normal((REPLICAS, 1))


def replicas(rng: np.random.Generator, offset_sd: float = 0.0) -> list[xr.Dataset]:
    """Synthetic replicas as the workflow's fields files hold them (:func:`replica_noise`)."""
    attrs = {"d": D, "z_bottom_wall": 0.0, "z_top_wall": 22 * D}
    return [xr.Dataset({"nu": ("z", TRUTH + e), "nu_err": ("z", np.full(N_POINTS, SIGMA))}, coords={"z": Z}, attrs=attrs)
            for e in replica_noise(rng, offset_sd)]


def nominal_difference(rng: np.random.Generator, theta_b: float, offset_sd: float = 0.0) -> float:
    """S_B - S_A of one rerun: new DEM replicas, a new calibration estimate of each parameter.
    (The replicas' mean straight from their noise: building 3000 x 3 datasets per spread cost 80 %
    of this file's time, with the same random numbers drawn.)"""
    dem = TRUTH + replica_noise(rng, offset_sd).mean(axis=0)
    a = rng.normal(THETA_A, S_THETA)
    b = rng.normal(theta_b, S_THETA)
    return rmse(TRUTH + b * shape_b(), dem, dem) - rmse(TRUTH + a * SHAPE_A, dem, dem)


@functools.lru_cache(maxsize=None)
def true_spread(theta_b: float, offset_sd: float = 0.0) -> tuple[float, float]:
    """Mean and standard deviation of S_B - S_A over independent reruns (the truth to test against)."""
    rng = np.random.default_rng(1)
    d = np.array([nominal_difference(rng, theta_b, offset_sd) for _ in range(3000)])
    return float(d.mean()), float(d.std(ddof=1))


@functools.lru_cache(maxsize=None)
def theta_b_for(ratio: float) -> float:
    """The B parameter whose mean score difference is ``ratio`` times its own spread."""
    theta_b = THETA_A / np.sqrt(np.mean(SHAPE_B**2))
    for _ in range(4):
        mean, sd = true_spread(theta_b)
        theta_b += (ratio * sd - mean) / np.sqrt(np.mean(SHAPE_B**2))
    return theta_b


def samples_of_one_rerun(rng: np.random.Generator, theta_b: float, offset_sd: float = 0.0) -> dict[str, ScoreSamples]:
    """What the workflow computes for the two models on one rerun."""
    reps = replicas(rng, offset_sd)
    dem = np.mean([ds.nu.values for ds in reps], axis=0)
    err = np.sqrt(np.sum([ds.nu_err.values**2 for ds in reps], axis=0)) / REPLICAS
    noise = dem_noise_model(reps, "nu")
    resampled = resample_profile(dem, err, noise, RESAMPLES, rng, log=False)
    offset = offset_noise(np.array([ds.nu.values for ds in reps]), np.array([ds.nu_err.values for ds in reps]), noise, False)
    shifted = offset_profiles(dem, err, offset, REPLICAS, RESAMPLES, rng, False)
    estimates = {"a": (rng.normal(THETA_A, S_THETA), SHAPE_A), "b": (rng.normal(theta_b, S_THETA), shape_b())}
    draws = rng.standard_normal((DRAWS, 2)) * S_THETA
    out = {}
    for j, (name, (theta, shape)) in enumerate(estimates.items()):
        model = TRUTH + theta * shape
        out[name] = ScoreSamples(rmse(model, dem, err), np.array([rmse(model, r, err) for r in resampled]),
                                 np.array([rmse(TRUTH + (theta + draws[k, j]) * shape, dem, err) for k in range(DRAWS)]),
                                 rmse(model, dem, err), noise.dof, points=[f"{N_POINTS} z points"],
                                 dem_offset=(np.array([rmse(model, r, err) for r in shifted]) if offset.variance > 0
                                             else np.array([])), offset_dof=offset.dof)
    return out


@pytest.mark.parametrize("ratio, apart", [(4.0, True), (0.5, False)])
def test_ranking_calls_a_known_difference_at_its_stated_coverage(ratio: float, apart: bool, rng) -> None:
    """Apart at 4x the difference's uncertainty, together at 0.5x, in at least 90 % of 50 reruns
    (expected for a 95 % interval with the true uncertainty: 98 % and 93 %)."""
    theta_b = theta_b_for(ratio)
    called_apart = 0
    for _ in range(50):
        rows, _ = judge_metric("synthetic", "nu_rmse", ["a", "b"], samples_of_one_rerun(rng, theta_b), 0.95)
        verdict = {r["model"]: r["verdict"] for r in rows}
        called_apart += "worse" in verdict.values()
    rate = called_apart / 50 if apart else 1.0 - called_apart / 50
    assert rate >= 0.9, (ratio, called_apart)


def test_the_stated_uncertainty_of_a_difference_matches_its_spread_over_reruns(rng) -> None:
    """The interval's half-width over 1.96 is, on average, the spread of the difference over
    independent reruns (to 15 %: 40 reruns estimate a standard deviation to about 11 %)."""
    theta_b = theta_b_for(1.0)
    _, spread = true_spread(theta_b)
    stated = [compare(s["b"], s["a"], 0.95).u for s in (samples_of_one_rerun(rng, theta_b) for _ in range(40))]
    assert np.mean(stated) == pytest.approx(spread, rel=0.15)


def test_a_whole_profile_offset_between_replicas_is_carried(rng, monkeypatch) -> None:
    """Replicas that differ by a whole-profile offset the stated errors do not hold, and two models
    on either side of the truth (so the offset moves their scores apart): the stated uncertainty of
    their difference, which then takes the offset from the replicas, still matches the spread over
    reruns (to 30 %: with 3 replicas the offset's variance has 2 degrees of freedom)."""
    monkeypatch.setitem(B_SIDE, "sign", -1.0)
    offset_sd = 0.004
    theta_b = theta_b_for(1.0)
    _, spread = true_spread(theta_b, offset_sd)
    stated = [compare(s["b"], s["a"], 0.95).u for s in (samples_of_one_rerun(rng, theta_b, offset_sd) for _ in range(60))]
    _, without = true_spread(theta_b)
    assert spread > 1.3 * without  # the offset matters for this pair
    assert np.sqrt(np.mean(np.square(stated))) == pytest.approx(spread, rel=0.3)


def test_welch_satterthwaite_limits() -> None:
    """One part: its own degrees of freedom; two equal parts of nu each: 2 nu; an infinite part adds none."""
    assert welch_satterthwaite([(1.0, 5.0)]) == pytest.approx(5.0)
    assert welch_satterthwaite([(1.0, 5.0), (1.0, 5.0)]) == pytest.approx(10.0)
    assert welch_satterthwaite([(1.0, 5.0), (1.0, math.inf)]) == pytest.approx(20.0)


def test_per_point_scores_are_compared_on_the_points_both_cover() -> None:
    """A model that refuses a depth is compared with another on the depths both cover only."""
    terms_a = np.array([0.1, 0.2, 0.3])
    terms_b = np.array([np.nan, 0.2, 0.3])  # refuses the first depth

    def samples(terms: np.ndarray) -> ScoreSamples:
        dem = np.tile(terms, (20, 1)) + np.linspace(-0.01, 0.01, 20)[:, None]
        return ScoreSamples(math.nan, np.array([]), np.array([]), math.nan, 10.0, ["D5", "D7", "D9"], terms, dem,
                            np.tile(terms, (8, 1)), terms)

    rows, pairs = judge_metric("intruder", "intruder_speed_log_err", ["a", "b"], {"a": samples(terms_a), "b": samples(terms_b)},
                               0.95)
    by = {r["model"]: r for r in rows}
    assert by["a"]["points"] == "D7 D9"
    assert by["a"]["value"] == pytest.approx(by["b"]["value"])  # the same terms on the shared depths
    assert pairs[0]["difference"] == pytest.approx(0.0)


def test_scene_needs_the_simplest_model_adequate_on_every_metric() -> None:
    import pandas as pd

    verdicts = pd.DataFrame([
        {"case": "c", "metric": "log_velocity_rmse", "model": "local_mu_i", "verdict": "worse"},
        {"case": "c", "metric": "log_velocity_rmse", "model": "volume_averaged", "verdict": "best"},
        {"case": "c", "metric": "log_velocity_rmse", "model": "ngf", "verdict": "cannot_tell_apart"},
        {"case": "c", "metric": "velocity_rmse_rel", "model": "local_mu_i", "verdict": "best"},
        {"case": "c", "metric": "velocity_rmse_rel", "model": "volume_averaged", "verdict": "cannot_tell_apart"},
        {"case": "c", "metric": "velocity_rmse_rel", "model": "ngf", "verdict": "worse"},
    ])
    diffs = pd.DataFrame([{"case": "c", "metric": m, "model_a": "ngf", "model_b": "volume_averaged", "difference": 0.1,
                           "ci_high": 0.3, "claim": "cannot_tell_apart"} for m in ("log_velocity_rmse", "velocity_rmse_rel")])
    table = scene_needs(verdicts, diffs, {("c", "volume_averaged"): 1e-3, ("c", "ngf"): 2e-3})
    row = table.iloc[0]
    assert row.simplest_model == "volume_averaged"  # local mu(I) fails the creep, NGF the flow
    assert row.next_model == "ngf"
    assert "fluidity" in row.next_adds and row.simplest_solve_ms == pytest.approx(1.0)
