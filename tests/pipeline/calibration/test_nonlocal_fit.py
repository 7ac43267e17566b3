"""The non-local lengths fitted on a replica mean, with errors from the replicas (synthetic creep
profiles of a known NGF amplitude, no LIGGGHTS)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import xarray as xr

import continuum
from continuum.geometry import PlanarShear
from pipeline.calibration.nonlocal_fit import fit_replicas, jackknife_error
from pipeline.calibration.parameter_sets import CALIBRATION_DEFAULTS, ngf_parameters

D = 0.002
GEOMETRY = PlanarShear(depth=20 * D, wall_speed=0.1, wall_pressure=200.0, gravity=9.81, d=D, rho_s=2500.0,
                       normal_stress_ratio=1.05)
LOCAL = {"mu_s": 0.37, "mu_2": 0.9, "I_0": 0.45, "nu_c": 0.59, "a": 0.15}
CRITICAL = {"sin_phi": 0.37, "nu_ref": 0.59, "kappa": 0.001, "a": 0.15, "p_ref": 300.0, "n": 1.05}
PARAMS = {"local": {k: {"value": v} for k, v in LOCAL.items()},
          "critical_state": {k: {"value": v} for k, v in CRITICAL.items()},
          "normal_stresses": {"sigma_zz_over_p": {"value": 1.05}},
          "wall": {"slip_length": {"value": 0.0, "error": 0.0}}}
A_TRUE = 0.3
POINT_NOISE = 0.05       # log noise of one profile point (what the block errors state)
REALISATION = 0.8       # log-slope scatter between replicas (frozen structure the block errors miss)


def truth() -> xr.Dataset:
    params = replace(ngf_parameters(LOCAL | CRITICAL, A=A_TRUE))
    return continuum.solve("ngf", GEOMETRY, params, n_grid=400)


def replica(u_true: np.ndarray, z: np.ndarray, rng: np.random.Generator, run: str) -> xr.Dataset:
    depth = (GEOMETRY.depth - z) / GEOMETRY.depth
    log_u = np.log(u_true) + REALISATION * rng.standard_normal() * depth + POINT_NOISE * rng.standard_normal(z.size)
    u = np.exp(log_u)
    attrs = {"z_bottom_contact_plane": 0.0, "z_top_contact_plane": GEOMETRY.depth, "wall_speed": GEOMETRY.wall_speed,
             "wall_pressure": GEOMETRY.wall_pressure, "gravity": GEOMETRY.gravity, "d": D, "rho_s": GEOMETRY.rho_s,
             "case": "shear_gravity", "run": run}
    return xr.Dataset({"u_x": ("z", u), "u_x_err": ("z", POINT_NOISE * u)}, coords={"z": z}, attrs=attrs)


def calibration(rng: np.random.Generator, sol: xr.Dataset, n: int = 3) -> dict:
    z = np.linspace(0.5 * D, GEOMETRY.depth - 0.5 * D, 60)
    u_true = np.interp(z, sol.z.values, sol.u_x.values)
    keep = u_true > 1e-4 * GEOMETRY.wall_speed
    sets = [replica(u_true[keep], z[keep], rng, f"r{k + 1}") for k in range(n)]
    entries, _ = fit_replicas(PARAMS, sets, CALIBRATION_DEFAULTS, models=("ngf",))
    return entries["ngf"]["A"]


def test_the_fit_records_per_replica_values_and_a_jackknife(rng) -> None:
    entry = calibration(rng, truth())
    assert set(entry["per_replica"]) == {"r1", "r2", "r3"} and set(entry["leave_one_out"]) == {"r1", "r2", "r3"}
    assert entry["error"] == max(entry["error_jackknife"], entry["error_fit_curvature"])
    assert entry["fitted_on"] == "shear_gravity/r1+r2+r3 (replica mean)"
    assert abs(entry["value"] - A_TRUE) < 4 * entry["error"]


def test_replica_errors_match_the_spread_between_independent_calibrations(rng) -> None:
    """Over 16 calibrations of 3 replicas each, the stated (replica-based) error of A is the spread
    of A between calibrations, to within the estimates' own scatter; the fit's curvature alone,
    which sees only the point noise, understates it several times over."""
    sol = truth()
    entries = [calibration(rng, sol) for _ in range(16)]
    values = np.array([e["value"] for e in entries])
    spread = values.std(ddof=1)
    stated = np.sqrt(np.mean([e["error"] ** 2 for e in entries]))
    curvature = np.sqrt(np.mean([e["error_fit_curvature"] ** 2 for e in entries]))
    assert 0.6 < stated / spread < 1.6, (stated, spread)
    assert curvature / spread < 0.5, (curvature, spread)


def test_jackknife_of_a_mean_is_its_standard_error(rng) -> None:
    """For the mean itself, leave-one-out means give exactly s / sqrt(n)."""
    x = rng.normal(size=7)
    loo = [(x.sum() - xi) / 6 for xi in x]
    assert jackknife_error(loo) == pytest.approx(x.std(ddof=1) / np.sqrt(7))


def _with_halves(ds: xr.Dataset, first: np.ndarray, second: np.ndarray) -> xr.Dataset:
    """``ds`` with displacement creep (the whole window's its u_x) and its halves' creep ``first``,
    ``second`` (same relative error), the snapshot average too noisy to be chosen."""
    u = ds.u_x.values
    return ds.assign(u_x_err=("z", 10.0 * u), u_x_disp=("z", u), u_x_disp_err=("z", POINT_NOISE * u),
                     u_x_disp_first_half=("z", first), u_x_disp_first_half_err=("z", POINT_NOISE * first),
                     u_x_disp_second_half=("z", second), u_x_disp_second_half_err=("z", POINT_NOISE * second))


def test_lengths_fitted_on_each_half_give_the_age_error(rng) -> None:
    """Creep of an ageing bed: the first half's profile is NGF's with A = 0.36, the second's with A =
    0.25 (the whole window's A = 0.3). The halves' fits recover their own A, and the age error is
    half the log difference, which the draws add to the realisation error in quadrature."""
    from pipeline.calibration.draws import relative_draw_error, relative_replica_error

    z = np.linspace(0.5 * D, GEOMETRY.depth - 0.5 * D, 60)
    profiles = {}
    for a in (0.36, 0.25):
        sol = continuum.solve("ngf", GEOMETRY, ngf_parameters(LOCAL | CRITICAL, A=a), n_grid=400)
        profiles[a] = np.interp(z, sol.z.values, sol.u_x.values)
    u_true = np.interp(z, truth().z.values, truth().u_x.values)
    keep = (u_true > 1e-4 * GEOMETRY.wall_speed) & (profiles[0.25] > 1e-4 * GEOMETRY.wall_speed)
    sets = []
    for k in range(3):
        ds = replica(u_true[keep], z[keep], rng, f"r{k + 1}")
        noise = np.exp(POINT_NOISE * rng.standard_normal((2, keep.sum())))
        sets.append(_with_halves(ds, profiles[0.36][keep] * noise[0], profiles[0.25][keep] * noise[1]))
    entry = fit_replicas(PARAMS, sets, CALIBRATION_DEFAULTS, models=("ngf",))[0]["ngf"]["A"]
    age = entry["age"]
    # Point noise of 0.05 in log over ~50 points: the halves' A to a few per cent.
    assert age["first_half"] == pytest.approx(0.36, rel=0.1) and age["second_half"] == pytest.approx(0.25, rel=0.1)
    assert age["error_age_log"] == pytest.approx(0.5 * np.log(age["first_half"] / age["second_half"]))
    assert relative_draw_error(entry) == pytest.approx(np.hypot(relative_replica_error(entry), age["error_age_log"]))
    # Without the halves there is no age entry, and the draws' width is the realisation error alone.
    plain = calibration(rng, truth())
    assert "age" not in plain and relative_draw_error(plain) == relative_replica_error(plain)
