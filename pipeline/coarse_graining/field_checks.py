"""Physical checks of coarse-grained planar-shear profiles that no tuning can fake.

1. Momentum balance in the bulk (at least ``margin`` from each wall's grains): in steady planar
   flow ``d sigma_xz / dz = 0`` and ``d sigma_zz / dz = -rho_body g`` (compressive positive,
   gravity along -z, ``rho_body`` the density of the grains gravity acts on). Residuals are
   integrated forms, so they need no numerical derivative of noisy stresses:
   ``R_xz(z) = sigma_xz(z) - mean_bulk(sigma_xz)`` and
   ``R_zz(z) = S(z) - mean_bulk(S)`` with ``S(z) = sigma_zz(z) + g integral_{z0}^{z} rho_body dz'``;
   each reported as max |R| over the bulk divided by the bulk-mean p.
2. Wall stress: integrating the coarse-grained balance from below the bottom wall to a height
   ``z_e`` where every bottom-wall grain's kernel has ended (``z_e = max z_wall + cutoff``)
   gives exactly ``sigma_zz(z_e) = -F_z / A - g M(z_e) / A`` and ``sigma_xz(z_e) = -F_x / A``,
   ``F`` the time-averaged force of the grains on the bottom wall's grains and ``M(z_e) =
   sum_body m_i CDF(z_e - z_i)`` the kernel-weighted body mass below ``z_e`` (computed exactly
   from the particles); at the top wall, ``z_e = min z_wall - cutoff`` and
   ``sigma_zz(z_e) = F_z / A + g M_above / A``, ``sigma_xz(z_e) = F_x / A``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import xarray as xr

from pipeline.coarse_graining.coarse_grain import batch, derive
from pipeline.common.statistics import integrated_autocorrelation_time
from pipeline.dumps.reader import Dump
from pipeline.coarse_graining.kernels import Kernel

BOTTOM_WALL_TYPE = 2
TOP_WALL_TYPE = 3


def _cumulative(values: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Trapezoid running integral from z[0]."""
    return np.concatenate([[0.0], np.cumsum(0.5 * (values[1:] + values[:-1]) * np.diff(z))])


def momentum_balance(ds: xr.Dataset, gravity: float, z_lo: float, z_hi: float) -> dict[str, float]:
    """Bulk momentum-balance residuals of a z profile between ``z_lo`` and ``z_hi`` (m)."""
    z = ds.variables["z"].values
    bulk = (z >= z_lo) & (z <= z_hi)
    if bulk.sum() < 3:
        raise ValueError(f"bulk [{z_lo:.4g}, {z_hi:.4g}] m holds fewer than 3 grid points")
    zb = z[bulk]
    p = float(np.mean(ds.variables["p"].values[bulk]))
    sxz = ds.variables["sigma_xz"].values[bulk]
    szz = ds.variables["sigma_zz"].values[bulk]
    rho = ds.variables["rho_body"].values[bulk]
    s = szz + gravity * _cumulative(rho, zb)
    zz_errors = ds.variables["sigma_zz_err"].values[bulk]
    expected = float(-gravity * np.mean(rho))
    xz_err = float(np.mean(ds.variables["sigma_xz_err"].values[bulk]))
    zz_err = float(np.mean(zz_errors))
    if np.all(zz_errors > 0):
        (slope, _), cov = np.polyfit(zb, szz, 1, cov="unscaled", w=1.0 / zz_errors)
        # The points share grains through the kernel (about width / spacing of them per independent
        # value): the straight-line fit's error, which takes them as independent, is scaled by its root.
        spacing = float(zb[1] - zb[0])
        shared = max(float(ds.attrs.get("width", spacing)) / spacing, 1.0)
        slope_err = float(math.sqrt(cov[0, 0] * shared))
    else:  # no time fluctuation (a static bed): no error to weigh or compare with
        slope, slope_err = float(np.polyfit(zb, szz, 1)[0]), float("nan")
    slope = float(slope)

    def over(value: float, error: float) -> float:
        return value / error if error > 0 else float("nan")

    xz_errors = ds.variables["sigma_xz_err"].values[bulk]
    with np.errstate(invalid="ignore", divide="ignore"):
        # RMS of the pointwise residual over its own error: 1 when the errors hold (the max above
        # is the largest of ~bulk / kernel-width independent values, ~2-2.5 errors by chance).
        rms_xz = float(np.sqrt(np.mean(((sxz - sxz.mean()) / xz_errors) ** 2))) if np.all(xz_errors > 0) else float("nan")
        rms_zz = float(np.sqrt(np.mean(((s - s.mean()) / zz_errors) ** 2))) if np.all(zz_errors > 0) else float("nan")
    return {
        "residual_xz_rms_over_err": rms_xz,
        "residual_zz_rms_over_err": rms_zz,
        "residual_xz_over_err": over(float(np.max(np.abs(sxz - sxz.mean()))), xz_err),
        "residual_zz_over_err": over(float(np.max(np.abs(s - s.mean()))), zz_err),
        "slope_zz_err": slope_err,
        "slope_zz_deviation_over_err": over(slope - expected, slope_err),
        "p_bulk": p,
        "residual_xz": float(np.max(np.abs(sxz - sxz.mean())) / p),
        "residual_zz": float(np.max(np.abs(s - s.mean())) / p),
        "sigma_xz_err_over_p": xz_err / p,
        "sigma_zz_err_over_p": zz_err / p,
        "slope_zz": slope,
        "slope_zz_expected": expected,
        "slope_xz": float(np.polyfit(zb, sxz, 1)[0]),
        "bulk_z_lo": float(zb[0]),
        "bulk_z_hi": float(zb[-1]),
    }


def mean_error(series: np.ndarray, blocks: int) -> float:
    """Standard error of the mean of a time series: the larger of the batch-means error over
    ``blocks`` blocks and ``std sqrt(2 tau / n)`` with tau its integrated autocorrelation time (the
    rule of :func:`pipeline.coarse_graining.coarse_grain.block_average`)."""
    series = np.asarray(series, dtype=float)
    n = series.size
    used = min(int(blocks), n)
    if used < 2:
        return float("nan")
    means = np.array([b.mean() for b in np.array_split(series, used)])
    block_err = float(means.std(ddof=1) / math.sqrt(used))
    tau = float(integrated_autocorrelation_time(series[:, None])[0])
    ac_err = float(series.std(ddof=1) * math.sqrt(2.0 * (tau if math.isfinite(tau) else 0.5) / n))
    return max(block_err, ac_err)


def slope_series_check(sums: np.ndarray, z: np.ndarray, z_lo: float, z_hi: float, gravity: float, d: float,
                       rho_s: float, blocks: int) -> dict[str, float]:
    """The hydrostatic slope of sigma_zz snapshot by snapshot, and the error of its mean.

    The pointwise errors of sigma_zz are strongly correlated along z (the load-controlled wall
    moves the whole bed: its vertical oscillation tilts the whole profile at once), so a line fit
    that takes the points as independent misjudges the slope's error. Here each snapshot's bulk
    profile gets its own least-squares slope and its own expected slope ``-g mean(rho_body)``; the
    mean deviation's error comes from the series of deviations, with its correlation time
    (:func:`mean_error`). The fit is linear in the stresses, so the mean of the snapshots' slopes
    is the slope of the mean profile (up to the kinetic stress's small nonlinearity).
    """
    bulk = (z >= z_lo) & (z <= z_hi)
    with np.errstate(invalid="ignore", divide="ignore"):
        fields = derive(np.moveaxis(sums[..., bulk], 0, 1), d, rho_s)
    szz, rho = fields["sigma_zz"], fields["rho_body"]  # (snapshots, bulk points)
    zb = z[bulk]
    slopes = np.polyfit(zb, szz.T, 1)[0]
    deviation = slopes + gravity * rho.mean(axis=1)
    err = mean_error(deviation, blocks)
    return {"slope_zz_series_err": mean_error(slopes, blocks),
            "slope_zz_series_deviation": float(deviation.mean()),
            # A static bed has no fluctuation: no error to compare with.
            "slope_zz_series_deviation_over_err": float(deviation.mean() / err) if err > 0 else float("nan")}


@dataclass
class WallGeometry:
    """Heights (m) of the wall grains: the bottom wall's highest and the top wall's lowest centre."""

    bottom_max: float
    top_min: float
    bottom_mean: float
    top_mean: float


def wall_geometry(particles: Dump, snapshots: np.ndarray) -> WallGeometry:
    """Wall-grain heights over the chosen snapshots (types 2 and 3)."""
    z = np.concatenate([particles.rows(s)[:, particles.index("z")] for s in snapshots])
    t = np.concatenate([particles.rows(s)[:, particles.index("type")] for s in snapshots]).astype(int)
    bottom, top = z[t == BOTTOM_WALL_TYPE], z[t == TOP_WALL_TYPE]
    if bottom.size == 0 or top.size == 0:
        raise ValueError("no wall grains (types 2 and 3) in the particle dump")
    return WallGeometry(float(bottom.max()), float(top.min()), float(bottom.mean()), float(top.mean()))


def body_mass_below(particles: Dump, snapshots: np.ndarray, kernel: Kernel, z_e: float,
                    body_types: tuple[int, ...] = (1,)) -> tuple[float, float]:
    """Time-averaged kernel-weighted body mass below and above ``z_e`` (kg): exact, via the CDF."""
    data = batch(particles, None, snapshots, body_types)
    weight = kernel.cdf(z_e - data.pos[:, 2])
    m = data.mass * data.body
    below = float(np.sum(m * weight)) / len(snapshots)
    return below, float(np.sum(m)) / len(snapshots) - below


def wall_contacts(particles: Dump, contacts: Dump, s: int) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Contacts of the non-wall grains with each wall's grains at particle snapshot ``s``:
    per wall, (force on the wall grain (N, rows x 3), contact point z (m))."""
    rows = particles.rows(s)
    ids = rows[:, particles.index("id")].astype(np.int64)
    types = np.zeros(ids.max() + 1, dtype=np.int64)
    types[ids] = rows[:, particles.index("type")].astype(np.int64)
    match = np.nonzero(contacts.timesteps == particles.timesteps[s])[0]
    crow = contacts.rows(int(match[0]))
    t1 = types[crow[:, contacts.index("id1")].astype(np.int64)]
    t2 = types[crow[:, contacts.index("id2")].astype(np.int64)]
    f = crow[:, [contacts.index("fx"), contacts.index("fy"), contacts.index("fz")]]
    cz = crow[:, contacts.index("cz")]
    out = {}
    for name, wall in (("bottom", BOTTOM_WALL_TYPE), ("top", TOP_WALL_TYPE)):
        # f is the force on particle 1: on a wall grain that is particle 2, the force is -f.
        first, second = (t1 == wall) & (t2 != wall), (t2 == wall) & (t1 != wall)
        out[name] = (np.concatenate([f[first], -f[second]]), np.concatenate([cz[first], cz[second]]))
    return out


def contact_wall_forces(particles: Dump, contacts: Dump, snapshots: np.ndarray) -> dict[str, np.ndarray]:
    """Per snapshot, the contact force (N, xyz) of the non-wall grains on each wall's grains,
    summed from the contact dump (the same snapshots the fields average)."""
    out: dict[str, list[np.ndarray]] = {"bottom": [], "top": []}
    for s in snapshots:
        for name, (force, _) in wall_contacts(particles, contacts, s).items():
            out[name].append(force.sum(axis=0))
    return {k: np.array(v) for k, v in out.items()}


def contact_planes(particles: Dump, contacts: Dump, snapshots: np.ndarray) -> tuple[float, float]:
    """Heights (m) where each wall's grains take the bed's load: the mean contact-point height of
    the bed-wall contacts, weighted by the normal (z) force each carries, over the snapshots.

    A continuum layer bounded by these planes carries the wall forces at its boundaries and the
    weight of the grains between them; the mean heights of the wall grains' centres lie about a
    grain radius outside them, and a model bounded there adds bed weight that is not there.
    """
    sums = {"bottom": [0.0, 0.0], "top": [0.0, 0.0]}
    for s in snapshots:
        for name, (force, cz) in wall_contacts(particles, contacts, s).items():
            w = np.abs(force[:, 2])
            sums[name][0] += float(np.sum(w * cz))
            sums[name][1] += float(np.sum(w))
    if not (sums["bottom"][1] > 0 and sums["top"][1] > 0):
        raise ValueError("no loaded bed-wall contacts in the contact dump: cannot place the wall planes")
    return sums["bottom"][0] / sums["bottom"][1], sums["top"][0] / sums["top"][1]


def stress_at(ds: xr.Dataset, name: str, z: float) -> tuple[float, float]:
    """Linear interpolation of a profile and of its error at height z."""
    zz = ds.variables["z"].values
    # ds.variables: the arrays without building a DataArray per access (40 us each).
    values, errors = ds.variables[name].values, ds.variables[f"{name}_err"].values
    return float(np.interp(z, zz, values)), float(np.interp(z, zz, errors))


def wall_stress(ds: xr.Dataset, kernel: Kernel, walls: WallGeometry, area: float, gravity: float,
                mass_below_bottom: float, mass_above_top: float,
                force_bottom: np.ndarray, force_top: np.ndarray) -> dict[str, float]:
    """Coarse-grained stress next to each wall against the wall force per area (see module doc).

    ``force_*`` are time-averaged forces (N, xyz) of the grains on the wall's grains."""
    z_b = walls.bottom_max + kernel.cutoff
    z_t = walls.top_min - kernel.cutoff
    out: dict[str, float] = {"z_bottom_check": z_b, "z_top_check": z_t}
    expected = {
        ("bottom", "sigma_zz"): -force_bottom[2] / area - gravity * mass_below_bottom / area,
        ("bottom", "sigma_xz"): -force_bottom[0] / area,
        ("top", "sigma_zz"): force_top[2] / area + gravity * mass_above_top / area,
        ("top", "sigma_xz"): force_top[0] / area,
    }
    for (wall, name), value in expected.items():
        got, err = stress_at(ds, name, z_b if wall == "bottom" else z_t)
        p, _ = stress_at(ds, "p", z_b if wall == "bottom" else z_t)
        out[f"{wall}_{name}"] = got
        out[f"{wall}_{name}_err"] = err
        out[f"{wall}_{name}_expected"] = float(value)
        # Two scales: the quantity itself, and the wall's normal stress (the load scale).
        out[f"{wall}_{name}_residual"] = float((got - value) / abs(value))
        out[f"{wall}_{name}_residual_over_normal"] = float((got - value) / abs(expected[(wall, "sigma_zz")]))
    return out


def contact_stress_identity(particles: Dump, contacts: Dump, snapshots: np.ndarray, kernel: Kernel,
                            walls: WallGeometry, gravity: float) -> dict[str, float]:
    """Per-snapshot identity of the contact stress at the wall check heights.

    For any height z_e, ``A sigma^c_az(z_e) = -sum_i W_i f^c_ia`` with ``W_i = CDF(z_e - z_i)``:
    the line integral telescopes over each contact. With ``f^c_i`` summed from the contact dump
    itself this is exact algebra, so ``exact_*`` tests the line integral, the minimum image, the
    force sign and the inclusion of flowing-wall contacts to rounding (no steady state needed).
    ``applied_*`` instead takes ``f^c = f - m g`` from the particle dump's total force on each
    flowing grain: it measures how far the contact dump's forces differ from the forces LIGGGHTS
    applied at that step. Both are the largest |mismatch| over the snapshots over |sigma_zz|.
    """
    from pipeline.coarse_graining.coarse_grain import SUMS, Grid, profile_sums

    worst: dict[str, float] = {}
    data = batch(particles, contacts, snapshots)
    rows = np.concatenate([particles.rows(int(s)) for s in snapshots])
    ids = rows[:, particles.index("id")].astype(np.int64)
    psid, csid = data.psid, data.csid
    assert psid is not None and csid is not None and data.areas is not None
    # Row of (snapshot, id) in the batch: ids are unique within a snapshot (a dense lookup table).
    stride = ids.max() + 1
    where = np.empty(len(snapshots) * stride, np.int64)
    where[psid * stride + ids] = np.arange(ids.size)
    crow = np.concatenate([contacts.rows(int(np.nonzero(contacts.timesteps == particles.timesteps[s])[0][0]))
                           for s in snapshots])
    i1 = where[csid * stride + crow[:, contacts.index("id1")].astype(np.int64)]
    i2 = where[csid * stride + crow[:, contacts.index("id2")].astype(np.int64)]
    # fc[i1] += f then fc[i2] -= f, accumulated in the same order as np.add.at (a 2D add.at is slow).
    both = np.concatenate([i1, i2])
    fc = np.stack([np.bincount(both, np.concatenate([data.force[:, a], -data.force[:, a]]), ids.size)
                   for a in range(3)], axis=1)
    applied = rows[:, [particles.index("fx"), particles.index("fy"), particles.index("fz")]] \
        - data.mass[:, None] * np.array([0.0, 0.0, -gravity])
    flow = rows[:, particles.index("type")].astype(int) == 1
    applied = np.where(flow[:, None], applied, fc)  # wall grains: their contact force either way
    nsnap = len(snapshots)
    far = 2.0 * float(np.ptp(data.pos[:, 2])) + 4.0 * kernel.cutoff
    for wall, z_e in (("bottom", walls.bottom_max + kernel.cutoff), ("top", walls.top_min - kernel.cutoff)):
        weight = kernel.cdf(z_e - data.pos[:, 2])
        # Contact sums only, at z_e: the grid's first point. The second lies beyond every grain, so
        # only the contacts near z_e are evaluated.
        sums = profile_sums(data, kernel, Grid(np.array([z_e, z_e + far])), particles=False)
        got = {name: sums[:, SUMS.index(f"c_{name}"), 0] for name in ("xz", "zz")}
        for label, forces in (("exact", fc), ("applied", applied)):
            expected = np.stack([np.bincount(psid, forces[:, a] * weight, nsnap) for a in range(3)], axis=1)
            expected = -expected / data.areas[:, None]
            for name, axis in (("xz", 0), ("zz", 2)):
                mismatch = np.abs(got[name] - expected[:, axis]) / np.abs(got["zz"])
                worst[f"{label}_{wall}_{name}"] = float(mismatch.max())
    return worst
