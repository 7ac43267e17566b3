"""Do the stated errors of the scalars hold? Replica scatter against the stated errors of every
scalar the calibration and the scores read: the rheometer states' bulk mu, nu and I, the planar
runs' wall friction, the intruder rods' speeds; and the creep of each planar run's production in
its first half against its second (creep still relaxing shows as a second half slower beyond the
errors).

For a scalar measured in n >= 2 replicas of one state (a rheometer state, a planar case, a rod
depth), ``sum_r (x_r - xbar)^2 / err_r^2`` (xbar the inverse-variance mean) is chi-squared with
n - 1 degrees of freedom if the stated errors are right; the groups are pooled:
``chi2 = sum over groups / sum (n_g - 1)``, its standard error ``sqrt(2 / dof)``. ``error_scale``
is ``sqrt(chi2)`` where chi2 departs from 1 by more than twice its error (the stated errors are to
be multiplied by it), else 1.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import xarray as xr
from scipy import stats

from pipeline.common.statistics import (NO_CHECK, chi2_of_deviates, chi2_row, error_scale,  # noqa: F401 (error_scale: used by error_check)
                                        independent_points, integrated_autocorrelation_time, normal_equivalent,
                                        pooled_chi2, welch_dof)

SCALAR_COLUMNS = ["case", "field", "chi2", "chi2_err", "pairs", "points", "replicas", "dof", "p_value",
                  "correlation_points", "error_scale"]
#: Fraction of a normal deviate beyond 2 in size: what ``|z_normal| > 2`` counts read against.
STEADY_BEYOND_TWO = float(2.0 * stats.norm.sf(2.0))
HALVES_COLUMNS = ["case", "run", "depth_over_d", "first_over_v", "first_err_over_v", "second_over_v",
                  "second_err_over_v", "log10_change", "log10_change_err", "z", "dof", "p_value", "z_normal"]


def rheometer_rows(states: dict[str, list[xr.Dataset]]) -> list[dict]:
    """``bulk_mu``, ``bulk_nu``, ``bulk_I`` of the rheometer: ``states`` maps a state (run id without
    its replica) to its replicas' fields."""
    rows = []
    for name in ("mu", "nu", "I"):
        groups = [(np.array([float(ds.attrs[f"bulk_{name}"]) for ds in reps]),
                   np.array([float(ds.attrs[f"bulk_{name}_err"]) for ds in reps])) for reps in states.values()]
        rows.append({"case": "rheometer", "field": f"bulk_{name}", **pooled_chi2(groups)})
    return rows


def wall_friction_row(case: str, reps: list[xr.Dataset]) -> dict:
    """The top wall's friction of a planar case's replicas."""
    have = [ds for ds in reps if "wall_friction" in ds.attrs]
    group = (np.array([float(ds.attrs["wall_friction"]) for ds in have]),
             np.array([float(ds.attrs["wall_friction_err"]) for ds in have]))
    return {"case": case, "field": "wall_friction", **pooled_chi2([group])}


def rod_speed_row(runs: list[dict]) -> dict:
    """The moving sheared rods' speeds, by scene: the replicas of one target depth and one push form
    a group (the depth sweep's run and the force sweep's at the same depth are other scenes)."""
    groups: dict[tuple[float, bool, float], list[tuple[float, float]]] = {}
    for r in runs:
        rod = r["intruder"]
        if rod["control"] or rod["arrested"]:
            continue
        scene = (round(rod["depth_target_over_d"], 6), bool(rod.get("force_sweep", False)), round(rod["force_fraction"], 6))
        groups.setdefault(scene, []).append((rod["speed"], rod["speed_err"]))
    pooled = pooled_chi2((np.array([s for s, _ in g]), np.array([e for _, e in g])) for g in groups.values())
    return {"case": runs[0]["case"] if runs else "intruder", "field": "rod_speed", **pooled}


def halves_row(case: str, run: str, depth_over_d: float, first: float, first_err: float, second: float,
               second_err: float, wall_speed: float, blocks: float = math.nan) -> dict | None:
    """One row of the halves table (speeds in m/s, over ``wall_speed``), its log10 change and z;
    None where either half is not resolved (above twice its error).

    Each half's error is a batch-means error of ``blocks`` blocks (``blocks - 1`` degrees of
    freedom), so z is Student's t with the Welch-Satterthwaite ``dof``, not a normal deviate: with
    few blocks |z| > 2 is common in a steady run (18 % at 2 dof). ``p_value`` is the two-sided
    probability of so large a change in a steady run, ``z_normal`` the normal deviate of the same
    probability (signed as z), so that counts beyond 2 read against 4.6 %. NaN where ``blocks`` is
    not known (a file from before it was recorded)."""
    if not (first > 2 * first_err and second > 2 * second_err):
        return None
    change = math.log10(second / first)
    rel_a, rel_b = first_err / first, second_err / second
    change_err = math.hypot(rel_a, rel_b) / math.log(10.0)
    z = change / change_err
    dof = p_value = z_normal = math.nan
    if blocks >= 2:
        dof = welch_dof(rel_a ** 2, rel_b ** 2, blocks, blocks)
        z_normal, p_value = normal_equivalent(z, dof)
    return {"case": case, "run": run, "depth_over_d": depth_over_d,
            "first_over_v": first / wall_speed, "first_err_over_v": first_err / wall_speed,
            "second_over_v": second / wall_speed, "second_err_over_v": second_err / wall_speed,
            "log10_change": change, "log10_change_err": change_err, "z": z,
            "dof": dof, "p_value": p_value, "z_normal": z_normal}


def beyond_two(halves: pd.DataFrame) -> tuple[int, int]:
    """Rows of a halves table whose ``|z_normal|`` exceeds 2, and the rows whose z_normal is known."""
    known = halves.z_normal.astype(float)
    known = known[np.isfinite(known)]
    return int((known.abs() > 2.0).sum()), int(known.size)


def halves_by_run(halves: pd.DataFrame) -> pd.DataFrame:
    """One row per run of a halves table: its depths compared, those beyond 2 (:func:`beyond_two`)
    and the :data:`STEADY_BEYOND_TWO` share a steady run would give, the mean log10 change (second
    half over first, decades; negative: the creep slowed) and the mean z_normal. Neighbouring depths
    share the kernel and the creep's own structure, so their z are correlated: the mean z is a
    summary, not a test."""
    rows = []
    for (case, run), frame in halves.groupby(["case", "run"], sort=True):
        beyond, known = beyond_two(frame)
        rows.append({"case": case, "run": run, "depths": len(frame), "beyond_2": beyond,
                     "expected_beyond_2": round(STEADY_BEYOND_TWO * known, 1),
                     "mean_log10_change": float(frame.log10_change.mean()),
                     "mean_z_normal": float(frame.z_normal.astype(float).mean()) if known else math.nan})
    return pd.DataFrame(rows)


def creep_halves(ds: xr.Dataset) -> pd.DataFrame:
    """First-half against second-half creep of one planar run, at every whole d below the top
    contact plane inside the walls where both halves are resolved (above twice their errors)."""
    if "u_x_disp_first_half" not in ds:
        return pd.DataFrame(columns=HALVES_COLUMNS)
    d, v = float(ds.attrs["d"]), float(ds.attrs["wall_speed"])
    depth = (float(ds.attrs["z_top_contact_plane"]) - ds.z.values) / d
    height = (ds.z.values - float(ds.attrs["z_bottom_contact_plane"])) / d
    order = np.argsort(depth)
    rows = []
    for target in np.arange(1.0, math.floor(depth.max()), 1.0):
        if np.interp(target, depth[order], height[order]) < 1.0:
            break
        a, ea, b, eb = (float(np.interp(target, depth[order], ds[n].values[order])) for n in
                        ("u_x_disp_first_half", "u_x_disp_first_half_err", "u_x_disp_second_half", "u_x_disp_second_half_err"))
        row = halves_row(str(ds.attrs.get("case", "")), str(ds.attrs.get("run", "")), float(target), a, ea, b, eb, v,
                         float(ds.attrs.get("half_window_blocks", math.nan)))
        if row is not None:
            rows.append(row)
    return pd.DataFrame(rows, columns=HALVES_COLUMNS)


def _moving_rod_halves(runs: list[dict]):
    """(run record, rod record, halves) of every moving sheared rod whose record has its halves."""
    for r in runs:
        rod = r["intruder"]
        if not (rod["control"] or rod["arrested"] or not rod.get("halves")):
            yield r, rod, rod["halves"]


def rod_halves(runs: list[dict]) -> pd.DataFrame:
    """First-half against second-half speed of every moving sheared rod's production (``halves`` of
    its run record, pipeline.dem.intruder_run.production_halves), in the creep halves' columns:
    ``depth_over_d`` is the rod's target depth (its run id), speeds over the wall speed. A rod is
    left out where either half is not resolved (above twice its error)."""
    rows = []
    for r, rod, halves in _moving_rod_halves(runs):
        v = rod["speed"] / rod["speed_over_wall_speed"]
        row = halves_row(r["case"], r["run"], float(rod["depth_target_over_d"]),
                         *(float(halves[k]) for k in ("first", "first_err", "second", "second_err")), v,
                         float(halves.get("blocks", math.nan)))
        if row is not None:
            rows.append(row)
    return pd.DataFrame(rows, columns=HALVES_COLUMNS)


def rod_halves_row(runs: list[dict]) -> dict:
    """``rod_speed_halves``: each moving sheared rod's first-half against second-half speed, one
    deviate per run. It tests the time error alone, the halves sharing the rod's neighbourhood;
    ``rod_speed`` (the replicas) adds the frozen packing's scatter.

    Each half's error is a batch-means error of ``blocks`` blocks, so ``(second - first) / error``
    is Student's t with the Welch-Satterthwaite dof (about 14 at 8 blocks a half), whose square
    averages dof / (dof - 2) = 1.17 in a steady run, not 1: each t is read as its normal
    equivalent (:func:`pipeline.common.statistics.normal_equivalent`) and ``chi2`` is their mean
    square. A record without ``blocks`` (from before it was recorded) takes its t as normal."""
    deviates = []
    for _, _, h in _moving_rod_halves(runs):
        a, ea, b, eb = (float(h[k]) for k in ("first", "first_err", "second", "second_err"))
        if not (ea > 0 and eb > 0 and all(map(math.isfinite, (a, ea, b, eb)))):
            continue
        t = (b - a) / math.hypot(ea, eb)
        blocks = float(h.get("blocks", math.nan))
        deviates.append(normal_equivalent(t, welch_dof(ea ** 2, eb ** 2, blocks, blocks))[0] if blocks >= 2 else t)
    return {"case": runs[0]["case"] if runs else "intruder", "field": "rod_speed_halves",
            **chi2_of_deviates(deviates), "replicas": 2}


def creep_halves_row(halves: pd.DataFrame, case: str) -> dict:
    """``creep_halves``: the planar runs of ``case``, first half of each production against the
    second (the ``z_normal`` of ``validation/creep_halves.csv``, normal deviates if the creep is
    steady within its stated time errors), as one chi2. A run's depths share grains and bursts, so
    its independent points are counted as the profiles' are (:func:`pipeline.scoring.error_check.
    replica_chi2`): ``points / (2 tau)``, ``tau`` the integrated autocorrelation time (in points)
    of its z along depth, at least one point a run. The runs are pooled: ``chi2 = sum_runs
    mean(z^2) * independent / sum_runs independent``. A drift or an understated time error raises
    chi2 above 1 beyond ``chi2_err``; ``pairs`` counts the runs, ``correlation_points`` is the
    runs' mean tau."""
    total, dof, taus, points, runs = 0.0, 0.0, [], 0, 0
    for _, run in halves[halves.case == case].groupby("run"):
        z = run.sort_values("depth_over_d").z_normal.astype(float).to_numpy()
        z = z[np.isfinite(z)]
        if z.size == 0:
            continue
        tau = float(integrated_autocorrelation_time(z)) if z.size >= 2 else 0.5
        tau = tau if math.isfinite(tau) else 0.5
        independent = independent_points(z.size, tau)
        total += float(np.mean(z ** 2)) * independent
        dof += independent
        taus.append(tau)
        points += int(z.size)
        runs += 1
    if runs == 0:
        return {"case": case, "field": "creep_halves", **NO_CHECK}
    return {"case": case, "field": "creep_halves", **chi2_row(total, dof, pairs=runs, points=points, replicas=2),
            "correlation_points": float(np.mean(taus))}
