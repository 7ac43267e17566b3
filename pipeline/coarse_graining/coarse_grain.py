"""Coarse-grain DEM particles and contacts into continuum fields (Goldhirsch 2010; Weinhart et al. 2012).

Conventions (docs/physics.md): compressive stress positive; flow x, gradient z (up), vorticity y.
With the product kernel of :mod:`pipeline.coarse_graining.kernels` integrated exactly over the periodic x and y
(profiles, per unit area ``A = Lx Ly``) or over y (x-z fields, per unit length ``Ly``):

- density ``rho = sum_i m_i phi(r - r_i)``; solid fraction ``nu = sum_i V_i phi`` (``V = 4/3 pi R^3``);
- velocity ``u = <sum m v phi> / <rho>`` (momentum over density, both time-averaged: Favre mean);
- kinetic stress ``<sum m v v phi> - <rho> u u``: fluctuations about the time-averaged local mean
  velocity, so that the time-averaged fields obey the time-averaged momentum balance;
- contact stress ``sum_c f_c (x) r_c * integral_0^1 phi(r - r_1 + s r_c) ds`` with ``f_c`` the
  force on particle 1 and ``r_c = r_1 - r_2`` (minimum image across periodic faces), summed over
  every contact in the dump, flowing-wall contacts included; on profiles the line integral is exact
  (an erf or polynomial difference, :meth:`Kernel.segment`), on x-z planes a Gauss-Legendre rule
  along grain branches, checked against the exact integral per run (:mod:`pipeline.coarse_graining.plane`,
  :func:`_check_contact_rule`). ``sigma_ab = sum f_a r_b ...`` so that the
  momentum balance reads ``d sigma_xz / dz = 0``, ``d sigma_zz / dz = -rho g`` in steady planar
  flow. With this sign ``sigma_xz`` is negative where ``du_x/dz > 0``.
- ``p = trace / 3``; ``mu = |sigma_xz| / p``; ``shear_rate = du_x/dz`` differentiated exactly
  (the kernel derivative applied to the time-averaged momentum and density); ``I = |shear_rate|
  d / sqrt(p / rho_s)``.

Errors: the snapshots in the window are split into ``blocks`` contiguous blocks (default 5);
every field is computed from each block's averages and its standard error is the standard
deviation of the block values over sqrt(blocks).

Command line: :mod:`pipeline.coarse_graining.dumps_cli` (``python -m pipeline.coarse_graining``).
"""
from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from pipeline.dumps.reader import Dump, check_particle_rows
from pipeline.common import atomic
from pipeline.common.statistics import integrated_autocorrelation_time
from pipeline.coarse_graining.deposit import SUMS, CoarseGrainError, Grid, SnapshotData
from pipeline.coarse_graining.kernels import Kernel
from pipeline.coarse_graining.pairing import contact_index
from pipeline.coarse_graining.plane import CONTACT_POINTS, plane_sums
from pipeline.coarse_graining.profile import FLAT_BRANCH, profile_sums

#: The names this module has long offered, now defined in the stage's smaller modules.
__all__ = ["BATCH_ROWS", "FIELDS", "FLAT_BRANCH", "SUMS", "CoarseGrainError", "Grid", "Result", "SnapshotData",
           "batch", "block_average", "coarse_grain", "derive", "plane_grid", "plane_sums", "profile_grid",
           "profile_sums", "snapshot", "write_netcdf"]

#: Particle rows coarse-grained in one vectorised pass (bounds the temporaries to ~100 MB).
BATCH_ROWS = 200_000

#: Output fields: (units, long name). Every field also gets an ``_err`` companion.
FIELDS: dict[str, tuple[str, str]] = {
    "nu": ("1", "solid fraction"),
    "rho": ("kg m-3", "mass density (all grains)"),
    "rho_body": ("kg m-3", "mass density of the grains gravity acts on"),
    "u_x": ("m s-1", "velocity along x (flow)"),
    "u_z": ("m s-1", "velocity along z (gradient, up)"),
    "shear_rate": ("s-1", "shear rate du_x/dz (exact derivative of the coarse-grained u_x)"),
    "sigma_xx": ("Pa", "normal stress xx, contact plus kinetic, compressive positive"),
    "sigma_yy": ("Pa", "normal stress yy, contact plus kinetic, compressive positive"),
    "sigma_zz": ("Pa", "normal stress zz, contact plus kinetic, compressive positive"),
    "sigma_xz": ("Pa", "shear stress xz (x force across z planes), contact plus kinetic, compressive-positive sign"),
    "sigma_xz_contact": ("Pa", "contact part of sigma_xz"),
    "sigma_xz_kinetic": ("Pa", "kinetic part of sigma_xz"),
    "sigma_zx_contact": ("Pa", "contact part of sigma_zx (z force across x planes; equals sigma_xz_contact on average)"),
    "sigma_zz_kinetic": ("Pa", "kinetic part of sigma_zz"),
    "p": ("Pa", "mean normal stress, trace / 3"),
    "mu": ("1", "stress ratio |sigma_xz| / p"),
    "I": ("1", "inertial number |shear_rate| d / sqrt(p / rho_s)"),
    "fluidity": ("s-1", "operational granular fluidity shear_rate / mu (Zhang & Kamrin 2017)"),
    "granular_temperature": ("m2 s-2", "granular temperature: trace of the kinetic stress / (3 rho), velocity "
                             "fluctuations about the local mean (includes the mean-flow variation within the kernel)"),
}


def profile_grid(z_lo: float, z_hi: float, bins: int | None = None, dz: float | None = None) -> Grid:
    """Uniform z centres from ``z_lo`` to ``z_hi`` (inclusive): ``bins`` points or spacing ``dz``."""
    if bins is None:
        if dz is None or dz <= 0:
            raise CoarseGrainError("give a positive bin count or spacing")
        bins = max(2, int(round((z_hi - z_lo) / dz)) + 1)
    if bins < 2 or not z_hi > z_lo:
        raise CoarseGrainError(f"need at least 2 bins over a positive range, got {bins} over [{z_lo}, {z_hi}]")
    return Grid(np.linspace(z_lo, z_hi, bins))


def plane_grid(x_lo: float, lx: float, z_lo: float, z_hi: float, dx: float, bins_z: int | None = None) -> Grid:
    """x-z grid: x centres cover the periodic length ``lx`` with a spacing near ``dx``."""
    nx = max(2, int(round(lx / dx)))
    x = x_lo + (np.arange(nx) + 0.5) * (lx / nx)
    return Grid(profile_grid(z_lo, z_hi, bins=bins_z, dz=None if bins_z else dx).z, x)


# ---------------------------------------------------------------------------------------------
# One snapshot


def snapshot(particles: Dump, contacts: Dump | None, s: int, body_types: Sequence[int] | None = (1,)) -> SnapshotData:
    """Arrays of particle snapshot ``s`` and of the contact snapshot at the same timestep."""
    data = batch(particles, contacts, np.array([s]), body_types)
    data.psid = data.csid = data.areas = data.lengths = None
    return data


def _rows(dump: Dump, snaps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of several snapshots and the batch index (0..len(snaps)-1) of each row."""
    counts = dump.counts[snaps]
    if snaps.size == 1:
        return dump.rows(int(snaps[0])), np.zeros(int(counts[0]), dtype=np.int64)
    if np.all(np.diff(snaps) == 1):  # consecutive snapshots (a time window): a view, no copy
        rows = dump.data[dump.offsets[snaps[0]]:dump.offsets[snaps[-1] + 1]]
    else:
        rows = np.concatenate([dump.rows(int(k)) for k in snaps])
    return rows, np.repeat(np.arange(snaps.size), counts)


def _columns(rows: np.ndarray, columns: Sequence[str], names: Sequence[str]) -> np.ndarray:
    """The named columns of ``rows``: a read-only view when they are adjacent and in order (no copy),
    else a copy."""
    idx = [columns.index(n) for n in names]
    if idx == list(range(idx[0], idx[0] + len(idx))):
        view = rows[:, idx[0]:idx[0] + len(idx)]
        view.flags.writeable = False
        return view
    return rows[:, idx]


def batch(particles: Dump, contacts: Dump | None, chosen: np.ndarray,
          body_types: Sequence[int] | None = (1,)) -> SnapshotData:
    """Arrays of several particle snapshots (and their contacts) for one vectorised pass."""
    chosen = np.asarray(chosen, dtype=np.int64)
    rows, psid = _rows(particles, chosen)
    cols = particles.columns
    pos = _columns(rows, cols, ("x", "y", "z"))
    vel = _columns(rows, cols, ("vx", "vy", "vz"))
    mass = rows[:, cols.index("mass")]
    radius = rows[:, cols.index("radius")]
    if body_types is not None and "type" in cols:
        body = np.isin(rows[:, cols.index("type")].astype(np.int64), np.asarray(body_types))
    else:
        body = np.ones(rows.shape[0], dtype=bool)
    boxes = particles.boxes[chosen]
    lengths = boxes[:, :, 1] - boxes[:, :, 0]
    periodic = tuple(flag.startswith("p") for flag in (particles.boundary + ("pp", "pp", "ff"))[:3])
    if contacts is not None:
        crow, csid = _rows(contacts, contact_index(particles, contacts, chosen))
        cc = contacts.columns
        r1 = _columns(crow, cc, ("x1", "y1", "z1"))
        r2 = _columns(crow, cc, ("x2", "y2", "z2"))
        force = _columns(crow, cc, ("fx", "fy", "fz"))
        branch = r1 - r2
        for axis in range(3):
            if periodic[axis]:
                # Minimum image: positions are wrapped into the box, contacts may cross a face.
                length = lengths[csid, axis]
                branch[:, axis] -= length * np.round(branch[:, axis] / length)
    else:
        r1 = branch = force = np.zeros((0, 3))
        csid = np.zeros(0, dtype=np.int64)
    return SnapshotData(pos, vel, mass, 4.0 / 3.0 * math.pi * radius**3, body, r1, branch, force, boxes[0], periodic,
                        psid, csid, lengths[:, 0] * lengths[:, 1], lengths)


# ---------------------------------------------------------------------------------------------
# Fields from sums


def derive(sums: np.ndarray, d: float, rho_s: float) -> dict[str, np.ndarray]:
    """Fields (see :data:`FIELDS`) from time-averaged :data:`SUMS` (first axis)."""
    s = {name: sums[k] for k, name in enumerate(SUMS)}
    rho = s["mass"]
    positive = rho > 0

    def ratio(num: np.ndarray, den: np.ndarray, ok: np.ndarray) -> np.ndarray:
        return np.divide(num, den, out=np.full(num.shape, np.nan), where=ok)

    u = {a: ratio(s[f"mom_{a}"], rho, positive) for a in "xyz"}
    kinetic = {ab: s[f"mvv_{ab}"] - np.where(positive, rho * u[ab[0]] * u[ab[1]], 0.0) for ab in ("xx", "yy", "zz", "xz")}
    sigma = {ab: s[f"c_{ab}"] + kinetic[ab] for ab in ("xx", "yy", "zz", "xz")}
    p = (sigma["xx"] + sigma["yy"] + sigma["zz"]) / 3.0
    shear_rate = ratio(s["dmom_x"] * rho - s["mom_x"] * s["dmass"], rho * rho, positive)
    loaded = p > 0
    mu = ratio(np.abs(sigma["xz"]), p, loaded)
    root = np.sqrt(np.where(loaded, p, 1.0) / rho_s)
    inertial = np.where(loaded, np.abs(np.nan_to_num(shear_rate)) * d / root, np.nan)
    inertial = np.where(np.isnan(shear_rate), np.nan, inertial)
    return {
        "nu": s["volume"], "rho": rho, "rho_body": s["mass_body"], "u_x": u["x"], "u_z": u["z"],
        "shear_rate": shear_rate,
        "sigma_xx": sigma["xx"], "sigma_yy": sigma["yy"], "sigma_zz": sigma["zz"], "sigma_xz": sigma["xz"],
        "sigma_xz_contact": s["c_xz"], "sigma_xz_kinetic": kinetic["xz"], "sigma_zx_contact": s["c_zx"],
        "sigma_zz_kinetic": kinetic["zz"], "p": p, "mu": mu, "I": inertial,
        "fluidity": ratio(shear_rate, mu, np.isfinite(mu) & (np.nan_to_num(mu) > 0)),
        "granular_temperature": ratio(kinetic["xx"] + kinetic["yy"] + kinetic["zz"], 3.0 * rho, positive),
    }


def block_average(stack: np.ndarray, blocks: int, d: float, rho_s: float) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], int]:
    """Fields of the mean over snapshots (axis 0) and their standard errors.

    The error of each field is the larger of two estimates: the scatter of ``blocks`` consecutive
    block means over sqrt(blocks), and the standard deviation of the per-snapshot field times
    sqrt(2 tau / n), tau the integrated autocorrelation time (:func:`integrated_autocorrelation_time`).
    Block means alone understate the error when the correlation time is not short against a block
    (a load-controlled wall oscillates slowly); the autocorrelation estimate alone is noisy with
    few snapshots. Returns (fields, errors, blocks used). With fewer than 2 snapshots the errors are NaN."""
    n = stack.shape[0]
    used = min(blocks, n)
    if used < 2:
        fields = derive(stack.mean(axis=0), d, rho_s)
        return fields, {k: np.full_like(v, np.nan) for k, v in fields.items()}, used
    # The overall mean and the block means in one (elementwise) derive: SUMS on the first axis,
    # then [overall, block 1, ..., block B].
    parts = np.array_split(np.arange(n), used)
    means = np.stack([stack.mean(axis=0)] + [stack[idx].mean(axis=0) for idx in parts], axis=1)
    everything = derive(means, d, rho_s)
    with np.errstate(invalid="ignore", divide="ignore"):
        per_snapshot = derive(np.moveaxis(stack, 0, 1), d, rho_s)
    fields = {k: v[0] for k, v in everything.items()}
    errors = {}
    for name in fields:
        values = everything[name][1:]
        finite = np.all(np.isfinite(values), axis=0)
        safe = np.where(finite, values, 0.0)
        block_err = np.where(finite, safe.std(axis=0, ddof=1) / math.sqrt(used), np.nan)
        series = per_snapshot[name]
        good = np.all(np.isfinite(series), axis=0)
        clean = np.where(good, series, 0.0)
        tau = integrated_autocorrelation_time(clean)
        ac_err = np.where(good, clean.std(axis=0, ddof=1) * np.sqrt(2.0 * np.nan_to_num(tau, nan=0.5) / n), 0.0)
        errors[name] = np.where(finite, np.maximum(block_err, ac_err), np.nan)
    return fields, errors, used


@dataclass
class Result:
    """Coarse-grained fields with errors, the raw per-snapshot sums and timing."""

    dataset: xr.Dataset
    sums: np.ndarray  # (snapshots, len(SUMS), *grid shape)
    seconds: float


#: Snapshots on which the x-z contact rule is checked against the exact integral (spread over the window).
RULE_CHECK_SNAPSHOTS = 8
#: The largest |rule - exact| / standard error, over every stress field's bins, the rule may leave;
#: beyond it the fields are recomputed with the exact integral.
RULE_CHECK_LIMIT = 0.1
#: The contact sums (columns of SUMS) and the stress field whose standard error each is checked against.
_RULE_CHECKED = {"c_xx": "sigma_xx", "c_yy": "sigma_yy", "c_zz": "sigma_zz", "c_xz": "sigma_xz", "c_zx": "sigma_zx_contact"}


def _check_contact_rule(particles: Dump, contacts: Dump, chosen: np.ndarray, sums: np.ndarray, kernel: Kernel,
                        grid: Grid, errors: dict[str, np.ndarray], body_types: Sequence[int] | None) -> dict[str, Any]:
    """The x-z contact rule (:mod:`pipeline.coarse_graining.plane`; ``sums``, per snapshot of
    ``chosen``, are its) against the exact integral on ``RULE_CHECK_SNAPSHOTS`` snapshots spread over
    the window: their mean difference in each contact stress over the field's standard error, at its
    largest over the bins. The attributes to write, ``contact_integral`` = "exact" when it exceeds
    ``RULE_CHECK_LIMIT`` (the caller recomputes)."""
    sample = np.unique(np.linspace(0, chosen.size - 1, min(RULE_CHECK_SNAPSHOTS, chosen.size)).astype(int))
    exact = plane_sums(batch(particles, contacts, chosen[sample], body_types), kernel, grid, exact=True)
    difference = (sums[sample] - exact).mean(axis=0)
    worst = 0.0
    for column, field in _RULE_CHECKED.items():
        err, gap = errors[field], np.abs(difference[SUMS.index(column)])
        ok = np.isfinite(err) & (gap > 0)  # a bin with no error (a bed frozen over the window) and a gap: inf
        if ok.any():
            with np.errstate(divide="ignore"):
                worst = max(worst, float(np.max(gap[ok] / err[ok])))
    ruled = worst <= RULE_CHECK_LIMIT
    return {"contact_integral": f"gauss_legendre_{CONTACT_POINTS}" if ruled else "exact",
            "contact_rule_check": worst,
            "contact_rule_check_description": f"max over the stress fields' bins of |rule - exact| / standard error, "
                                              f"mean of {sample.size} snapshots; the rule is kept up to "
                                              f"{RULE_CHECK_LIMIT:g} (pipeline/coarse_graining/plane.py)"}


def coarse_grain(particles: Dump, contacts: Dump | None, kernel: Kernel, grid: Grid, *,
                 snapshots: np.ndarray | None = None, d: float | None = None, rho_s: float | None = None,
                 blocks: int = 5, time_step: float | None = None,
                 body_types: Sequence[int] | None = (1,)) -> Result:
    """Time-averaged fields over the chosen particle snapshots (default all), on ``grid``.

    ``d`` (m) defaults to the mean particle diameter and ``rho_s`` (kg m-3) to the mean particle
    density, both from the dump; ``time_step`` (s) converts timesteps to times in the attributes.
    """
    t0 = time.perf_counter()
    chosen = np.arange(len(particles)) if snapshots is None else np.asarray(snapshots, dtype=np.int64)
    if chosen.size == 0:
        raise CoarseGrainError("no snapshot in the averaging window")
    check_particle_rows(particles, chosen)
    radius = particles.column("radius")
    if d is None:
        d = float(2.0 * radius.mean())
    if rho_s is None:
        rho_s = float(np.mean(particles.column("mass") / (4.0 / 3.0 * math.pi * radius**3)))
    plane = grid.x is not None
    # Snapshots in batches of about BATCH_ROWS particle rows (x-z: 16 times fewer, each row has a
    # 2D window): one vectorised pass each.
    limit = BATCH_ROWS // 16 if plane else BATCH_ROWS
    parts, rows = [], np.cumsum(particles.counts[chosen])
    groups = [g for g in np.split(chosen, np.searchsorted(rows, np.arange(limit, rows[-1], limit))) if g.size]
    for group in groups:
        data = batch(particles, contacts, group, body_types)
        parts.append(plane_sums(data, kernel, grid) if plane else profile_sums(data, kernel, grid))
    sums = np.concatenate(parts)
    fields, errors, used = block_average(sums, blocks, d, rho_s)
    rule: dict[str, Any] = {}
    if plane and contacts is not None:
        rule = _check_contact_rule(particles, contacts, chosen, sums, kernel, grid, errors, body_types)
        if rule["contact_integral"] == "exact":
            sums = np.concatenate([plane_sums(batch(particles, contacts, g, body_types), kernel, grid, exact=True)
                                   for g in groups])
            fields, errors, used = block_average(sums, blocks, d, rho_s)
    dims = ("x", "z") if plane else ("z",)
    coords = {"z": ("z", grid.z, {"units": "m", "long_name": "height (gradient direction, up)"})}
    if plane:
        coords["x"] = ("x", grid.x, {"units": "m", "long_name": "position along the flow (periodic)"})
    variables = {}
    for name, (units, long_name) in FIELDS.items():
        variables[name] = (dims, fields[name], {"units": units, "long_name": long_name})
        variables[f"{name}_err"] = (dims, errors[name], {"units": units, "long_name": f"standard error of {long_name}: "
                                                          f"the larger of {used} block means and the autocorrelation-time estimate"})
    steps = particles.timesteps[chosen]
    attrs: dict[str, Any] = {
        "kernel": kernel.name, "width": kernel.width, "kernel_cutoff": kernel.cutoff,
        "number_of_snapshots": int(chosen.size), "error_blocks": int(used), "d": d, "rho_s": rho_s,
        "timestep_first": int(steps[0]), "timestep_last": int(steps[-1]),
        "geometry": "plane_xz" if plane else "profile_z",
        "conventions": "compressive stress positive; x flow, z gradient (up), y vorticity; sigma_ab = sum f_a r_b "
                       "(x force across z planes for sigma_xz); mu = |sigma_xz| / p",
        "averaging": "profiles integrate x and y exactly over the periodic cell (per unit area); x-z fields integrate y"
                     if not plane else "fields integrate y exactly (per unit length of the periodic y)",
        "contacts_included": int(contacts is not None),
        **rule,
    }
    if time_step is not None:
        attrs["time_window"] = np.array([steps[0] * time_step, steps[-1] * time_step])
        attrs["time_step"] = time_step
    dataset = xr.Dataset(variables, coords=coords, attrs=attrs)
    return Result(dataset, sums, time.perf_counter() - t0)


def write_netcdf(ds: xr.Dataset, path: Path) -> None:
    """Write a fields dataset atomically with its CF metadata (:func:`pipeline.common.atomic.write_netcdf`)."""
    atomic.write_netcdf(ds, Path(path), title="granular-validate coarse-grained fields")
