"""Replica scatter against stated errors (pipeline.scoring.error_check) on replicas of known noise."""
from __future__ import annotations

import math

import numpy as np
import xarray as xr

from pipeline.scoring.error_check import replica_chi2


def replicas(rng, stated: float, true: float, n: int = 4) -> list[xr.Dataset]:
    z = np.linspace(0.0, 0.04, 161)
    out = []
    for _ in range(n):
        ds = xr.Dataset({"nu": ("z", 0.6 + true * rng.standard_normal(z.size)), "nu_err": ("z", np.full(z.size, stated))},
                        coords={"z": z}, attrs={"d": 0.002, "z_bottom_wall": 0.0, "z_top_wall": 0.04, "width": 0.00025})
        out.append(ds)
    return out


def test_right_errors_give_chi2_one_and_understated_ones_do_not(rng) -> None:
    good = replica_chi2(replicas(rng, 0.01, 0.01), "nu")
    assert abs(good["chi2"] - 1.0) < 3 * good["chi2_err"]
    low = replica_chi2(replicas(rng, 0.005, 0.01), "nu")
    assert low["chi2"] > 1.0 + 3 * low["chi2_err"]  # errors half the truth: chi2 about 4
    assert good["pairs"] == 6 and good["replicas"] == 4


def smooth_replicas(rng, stated: float, true: float, length: int, n: int = 3) -> list[xr.Dataset]:
    """Replicas whose noise is correlated over ``length`` points along z (a moving average)."""
    z = np.linspace(0.0, 0.04, 401)
    out = []
    for _ in range(n):
        white = rng.standard_normal(z.size + length)
        noise = np.convolve(white, np.ones(length) / math.sqrt(length), mode="valid")[:z.size]
        ds = xr.Dataset({"nu": ("z", 0.6 + true * noise), "nu_err": ("z", np.full(z.size, stated))},
                        coords={"z": z}, attrs={"d": 0.002, "z_bottom_wall": 0.0, "z_top_wall": 0.04})
        out.append(ds)
    return out


def test_correlated_profiles_count_fewer_independent_points(rng) -> None:
    # Noise correlated over 20 points: about a twentieth of the points are independent, so the
    # chi2's own error is about sqrt(20) times that of white noise, and right errors still give
    # a chi2 within it.
    results = [replica_chi2(smooth_replicas(rng, 0.01, 0.01, 20), "nu") for _ in range(40)]
    points = results[0]["points"]
    independent = np.array([r["dof"] / (r["replicas"] - 1) for r in results])
    assert 0.5 * points / 20 < np.median(independent) < 2.0 * points / 20
    inside = np.mean([abs(r["chi2"] - 1.0) < 2.0 * r["chi2_err"] for r in results])
    assert inside > 0.8  # about 95 % for a Gaussian chi2; the tau estimate's own noise widens it
    # The p-value of right errors is not small; of errors at a third of the truth it is.
    assert np.median([r["p_value"] for r in results]) > 0.2
    low = replica_chi2(smooth_replicas(rng, 0.0033, 0.01, 20), "nu")
    assert low["chi2"] > 4.0 and low["p_value"] < 1e-3


def test_rod_speeds_are_grouped_by_scene_not_by_depth_alone(rng) -> None:
    """Replicas of two pushes at one depth, each group's scatter equal to its stated error: chi2
    is 1 within its error. Pooled by depth alone, the pushes' 100x different speeds would give
    chi2 in the thousands (the default run's first error check said 120 that way)."""
    from pipeline.scoring.scalar_checks import rod_speed_row

    runs = []
    for sweep, fraction, speed in ((False, 0.5, 1e-3), (True, 0.9, 1e-1)):
        for _ in range(40):
            err = 0.1 * speed
            rod = {"control": False, "arrested": False, "depth_target_over_d": 7.0, "force_sweep": sweep,
                   "force_fraction": fraction, "speed": speed + err * rng.standard_normal(), "speed_err": err}
            runs.append({"case": "intruder", "intruder": rod})
    row = rod_speed_row(runs)
    assert row["dof"] == 2 * 39
    assert abs(row["chi2"] - 1.0) < 3 * row["chi2_err"], row


def test_rod_halves_test_the_time_error_alone(rng) -> None:
    """Halves that scatter by their stated errors: chi2 1 within its error, and z of unit spread in
    the halves table; a frozen offset between runs (replica scatter) does not enter it."""
    from pipeline.scoring.scalar_checks import rod_halves, rod_halves_row

    runs = []
    for k in range(60):
        speed = 1e-3 * 10 ** rng.normal(0.0, 0.5)  # each run's own frozen neighbourhood
        err = 0.05 * speed
        halves = {"first": speed + err * rng.standard_normal(), "first_err": err,
                  "second": speed + err * rng.standard_normal(), "second_err": err}
        rod = {"control": False, "arrested": False, "depth_target_over_d": 7.0, "speed": speed,
               "speed_over_wall_speed": speed / 0.1, "halves": halves}
        runs.append({"case": "intruder", "run": f"D7-r{k + 1}", "intruder": rod})
    row = rod_halves_row(runs)
    assert row["dof"] == 60 and abs(row["chi2"] - 1.0) < 3 * row["chi2_err"], row
    table = rod_halves(runs)
    assert len(table) == 60 and abs(table.z.std() - 1.0) < 0.3
    assert np.allclose(table.first_over_v, [r["intruder"]["halves"]["first"] / 0.1 for r in runs])


def test_halves_z_reads_against_students_t(rng) -> None:
    """Steady creep whose halves' errors come from 3 blocks each: |z| > 2 is common (Student t,
    about 2-4 dof), |z_normal| > 2 happens 4.55 % of the time, as for a normal deviate."""
    from pipeline.scoring.scalar_checks import halves_row

    blocks, beyond_z, beyond_normal, n = 3, 0, 0, 4000
    for _ in range(n):
        halves = []
        for _half in range(2):
            block_speeds = 1e-3 * (1.0 + 0.05 * rng.standard_normal(blocks))
            halves += [block_speeds.mean(), block_speeds.std(ddof=1) / np.sqrt(blocks)]
        row = halves_row("c", "r1", 5.0, *halves, 0.1, blocks)
        beyond_z += abs(row["z"]) > 2
        beyond_normal += abs(row["z_normal"]) > 2
        assert 2.0 <= row["dof"] <= 2 * (blocks - 1)
    expected = 0.0455 * n
    assert abs(beyond_normal - expected) < 4 * np.sqrt(expected), beyond_normal
    assert beyond_z > expected + 6 * np.sqrt(expected), beyond_z
    # Blocks not recorded: no dof, and no claim.
    assert np.isnan(halves_row("c", "r1", 5.0, 1e-3, 1e-5, 1e-3, 1e-5, 0.1)["z_normal"])


def test_rod_halves_read_their_few_blocks_as_students_t(rng) -> None:
    """Steady rods whose halves' errors come from 8 blocks each: the raw mean square of the halves'
    t is dof / (dof - 2) ~ 1.17, not 1; read as normal equivalents, ``rod_speed_halves`` is 1 within
    3 of its errors (2000 runs: the 1.17 bias is 5 errors away, so the test can tell them apart)."""
    from pipeline.scoring.scalar_checks import rod_halves_row

    blocks, runs, raw = 8, [], []
    for k in range(2000):
        halves: dict[str, float] = {"blocks": blocks}
        for half in ("first", "second"):
            block_speeds = 1e-3 * (1.0 + 0.1 * rng.standard_normal(blocks))
            halves[half], halves[f"{half}_err"] = block_speeds.mean(), block_speeds.std(ddof=1) / np.sqrt(blocks)
        raw.append((halves["second"] - halves["first"]) ** 2 / (halves["first_err"] ** 2 + halves["second_err"] ** 2))
        rod = {"control": False, "arrested": False, "depth_target_over_d": 7.0, "speed": 1e-3,
               "speed_over_wall_speed": 1e-2, "halves": halves}
        runs.append({"case": "intruder", "run": f"D7-r{k + 1}", "intruder": rod})
    row = rod_halves_row(runs)
    assert row["dof"] == 2000 and abs(row["chi2"] - 1.0) < 3 * row["chi2_err"], row
    assert np.mean(raw) - 1.0 > 3 * row["chi2_err"], np.mean(raw)
