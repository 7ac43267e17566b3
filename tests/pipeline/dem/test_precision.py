"""The production's stopping rule: batch-means errors of the scored fields against targets."""
from __future__ import annotations

import math

import numpy as np

from pipeline.dem import precision


def test_standard_error_is_the_error_of_the_mean(rng: np.random.Generator) -> None:
    # 4000 independent sets of 6 blocks of unit-variance noise: the stated error of each mean is
    # 1/sqrt(6) on average (within the chi distribution's bias), and the means scatter by it.
    blocks = rng.normal(size=(6, 4000))
    err = precision.standard_error(blocks)
    assert abs(np.sqrt(np.mean(err**2)) - 1.0 / math.sqrt(6.0)) < 0.02
    assert abs(blocks.mean(axis=0).std() - 1.0 / math.sqrt(6.0)) < 0.02


def test_fewer_blocks_than_the_minimum_give_no_error() -> None:
    assert np.all(np.isnan(precision.standard_error(np.ones((precision.MIN_BLOCKS - 1, 3)))))


def _means(rng: np.random.Generator, blocks: int, creep_noise: float) -> precision.ChunkMeans:
    d = 0.002
    depth = (np.arange(20) + 0.5) * d
    creep = np.exp(-depth / (2 * d))  # u/V from 0.8 at the wall to 5e-5 at 20 d
    return precision.ChunkMeans(
        u_x_over_v=creep + 0.001 * rng.normal(size=(blocks, 20)),
        nu=0.58 + 0.001 * rng.normal(size=(blocks, 20)),
        u_disp_over_v=creep + creep_noise * rng.normal(size=(blocks, 20)),
        depth=depth, bulk=(depth > 3 * d) & (depth < 17 * d))


def test_log_speed_target_depends_on_the_depth_scored(rng: np.random.Generator) -> None:
    # Noise 1e-4 V per block, 4e-5 on the mean of 6: at 4 d (u/V = 0.14) the log error is
    # 4e-5 / (0.14 ln10), tiny; at 19.5 d (u/V = 6e-5) the speed is not resolved at 2 sigma.
    means = _means(rng, 6, 1e-4)
    shallow = precision.measure(means, 0.002, None, {"log_speed": 0.1, "log_speed_depth_over_d": 4.0}, gravity=True)
    deep = precision.measure(means, 0.002, None, {"log_speed": 0.1, "log_speed_depth_over_d": 20.0}, gravity=True)
    assert shallow["all_met"] and shallow["reached"]["log_speed"] < 0.01
    assert not deep["all_met"] and deep["reached"]["log_speed"] == math.inf


def test_targets_of_the_geometry_only(rng: np.random.Generator) -> None:
    means = _means(rng, 4, 1e-4)
    targets = {"u_x_over_v": 0.01, "nu": 0.002, "mu": 0.008}
    out = precision.measure(means, 0.002, np.array([0.40, 0.41, 0.39, 0.40]), targets, gravity=False)
    assert set(out["reached"]) == {"u_x_over_v", "nu", "mu"}
    # The friction's blocks scatter by 0.008: error 0.004, its bound from 4 blocks 1.89 x that, within the target.
    assert abs(out["reached"]["mu"] - np.std([0.40, 0.41, 0.39, 0.40], ddof=1) / 2.0) < 1e-12
    assert out["all_met"]
    # With gravity too: tau, uniform in steady flow, sets the scored profile mu(z) = tau / p(z).
    assert precision.measure(means, 0.002, np.array([0.40, 0.41, 0.39, 0.40]), targets, gravity=True)["reached"]["mu"] \
        == out["reached"]["mu"]


def test_too_few_chunks_meet_nothing(rng: np.random.Generator) -> None:
    out = precision.measure(_means(rng, 2, 1e-4), 0.002, None, {"u_x_over_v": 1.0}, gravity=True)
    assert out == {"blocks": 2, "reached": {}, "bound": {}, "met": {}, "all_met": False}


def test_error_bound_covers_the_true_error_as_often_as_stated(rng: np.random.Generator) -> None:
    """20000 sets of n normal batch means with unit variance: the true error of their mean,
    1/sqrt(n), lies under the estimate x error_bound_factor(n) in 84 % of the sets (within the
    binomial scatter, 3 x sqrt(0.84 0.16 / 20000) = 0.008), for the few batches where it matters."""
    for n in (3, 4, 8):
        err = precision.standard_error(rng.normal(size=(n, 20000)))
        covered = np.mean(err * precision.error_bound_factor(n) >= 1.0 / math.sqrt(n))
        assert abs(covered - precision.ERROR_BOUND_CONFIDENCE) < 0.008, (n, covered)


def test_a_lucky_low_estimate_does_not_meet_the_target(rng: np.random.Generator) -> None:
    """Three batches whose scatter is a quarter of the others': the estimate is under the target,
    its bound is not, so production goes on."""
    means = _means(rng, 3, 1e-4)
    ratios = np.array([0.440, 0.4424, 0.4412])  # estimate 0.0007, bound 2.39 x that
    out = precision.measure(means, 0.002, ratios, {"mu": 0.0012}, gravity=True)
    assert out["reached"]["mu"] < 0.0012 < out["bound"]["mu"]
    assert not out["all_met"]
    assert out["bound"]["mu"] == out["reached"]["mu"] * precision.error_bound_factor(3)


def test_a_longer_case_cap_keeps_the_dumps_as_dense_in_strain(tmp_path) -> None:
    """cases.<case>.production_strain raises the cap, not the spacing of the snapshots: the
    chunk plan of a rheometer run with a doubled cap has twice the production chunks and the
    same dump interval."""
    from pipeline.common.config import load_config
    from pipeline.dem.planar_run import PlanarShearRun

    config = load_config("config/ci.yaml")
    run_id = "I0.07-P200-r1"
    plans = []
    for cap in (None, 2.0 * config["dem"]["production_strain"]):
        # ci.yaml's rheometer sets its own cap: without it, the case takes dem.production_strain.
        case = {k: v for k, v in config["cases"]["rheometer"].items() if k != "production_strain"}
        if cap is not None:
            case["production_strain"] = cap
        run = PlanarShearRun(config | {"cases": {"rheometer": case}}, "rheometer", run_id, tmp_path)
        run.state = {"fill": {"settled_gap": 0.03}}
        plans.append(run._chunk_plan())
    default, longer = plans
    assert longer["production_chunks"] == 2 * default["production_chunks"]
    assert longer["dump_every"] == default["dump_every"] and longer["chunk_steps"] == default["chunk_steps"]
