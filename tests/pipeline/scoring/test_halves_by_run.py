"""The production halves per run: what steady creep would give and what it gave."""
from __future__ import annotations

import numpy as np
import pandas as pd

from pipeline.scoring.scalar_checks import creep_halves_row, halves_by_run


def _halves(rng: np.random.Generator, run: str, shift: float, n: int = 400) -> pd.DataFrame:
    """``n`` depths of one run whose halves differ by ``shift`` decades, errors 0.05 decade."""
    err = 0.05
    change = shift + err * rng.standard_normal(n)
    z = change / err
    return pd.DataFrame({"case": "bed", "run": run, "depth_over_d": np.arange(1, n + 1, dtype=float),
                         "log10_change": change, "log10_change_err": err, "z": z, "z_normal": z})


def test_a_steady_run_has_its_share_beyond_two_and_a_slowing_one_more(rng: np.random.Generator) -> None:
    halves = pd.concat([_halves(rng, "steady", 0.0), _halves(rng, "ageing", -0.15)])
    table = halves_by_run(halves).set_index("run")
    steady, ageing = table.loc["steady"], table.loc["ageing"]
    # Binomial(400, 0.0455): mean 18.2, sd 4.2; four sd either side.
    assert abs(steady.beyond_2 - steady.expected_beyond_2) < 4 * np.sqrt(400 * 0.0455 * 0.9545)
    assert abs(steady.mean_log10_change) < 4 * 0.05 / np.sqrt(400)
    # A shift of 3 errors puts about 84 % of the depths beyond 2.
    assert ageing.beyond_2 > 0.75 * 400
    assert abs(ageing.mean_log10_change + 0.15) < 4 * 0.05 / np.sqrt(400)


def test_the_halves_chi2_is_one_for_steady_creep_counts_correlated_depths_and_flags_a_drift(
        rng: np.random.Generator) -> None:
    steady = pd.concat([_halves(rng, f"r{k}", 0.0) for k in range(1, 4)])
    row = creep_halves_row(steady, "bed")
    # Independent normal deviates: dof about the 1200 points, chi2 = 1 to sqrt(2 / dof) = 0.04.
    assert row["dof"] > 0.8 * 1200
    assert abs(row["chi2"] - 1.0) < 4 * row["chi2_err"]
    # Neighbouring depths sharing grains: a 9-point moving average of unit-variance noise, rescaled
    # to unit variance, has tau = 9 / 2 points, so about 1200 / 9 independent points.
    smooth = steady.copy()
    kernel = np.ones(9) / 3.0
    smooth["z_normal"] = np.concatenate([np.convolve(rng.standard_normal(408), kernel, mode="valid")
                                         for _ in range(3)])
    row = creep_halves_row(smooth, "bed")
    assert 0.5 * 1200 / 9 < row["dof"] < 2 * 1200 / 9
    assert abs(row["chi2"] - 1.0) < 4 * row["chi2_err"]
    # One run of three slowing by one error at every depth: chi2 about (1 + 1 + 2) / 3.
    drift = pd.concat([_halves(rng, "r1", 0.0), _halves(rng, "r2", 0.0), _halves(rng, "r3", -0.05)])
    row = creep_halves_row(drift, "bed")
    assert abs(row["chi2"] - 4.0 / 3.0) < 4 * row["chi2_err"]
    assert row["p_value"] < 1e-6 and row["error_scale"] > 1.0
