"""Creep speed from the grains' displacements over the whole window: ``u_x_disp``.

The snapshot-averaged velocity ``u_x`` averages instantaneous velocities: each snapshot carries
the full velocity fluctuation (of order the shear rate times d), so its error falls only as
1/sqrt(snapshots) and creep at 1e-4 of the wall speed drowns in it. The mean displacement of a
grain over the window divided by the window's duration is the same mean velocity, but its
fluctuating part is a bounded (caged) or diffusive excursion, so its error falls as 1/T (caged)
to 1/sqrt(T) (diffusive), whatever the snapshot count.

Definition, per grain i of the body (type 1): ``X_i`` = x unwrapped across the periodic
boundary from one snapshot to the next by the minimum image (valid while no grain moves half a
cell between two snapshots, which is checked), ``v_i = (X_i(t_end) - X_i(t_start)) / (t_end -
t_start)``, at the grain's time-mean height ``z_i``. Grains that move too far between two
snapshots to be unwrapped are not tracked, and the field is NaN where they carry more than
``UNTRACKED_WEIGHT_LIMIT`` of the kernel weight (the fast shear band of a run with few snapshots). The field is the mass-weighted kernel
average ``u_x_disp(z) = sum_i m_i v_i phi(z - z_i) / sum_i m_i phi(z - z_i)`` with the kernel of
the other fields. Its standard error is the batch-means error over ``blocks`` consecutive
sub-windows of equal length: the full-window value is the mean of the sub-window values, so the
scatter of those over sqrt(blocks) is its error when the sub-windows are independent. That is
exact for diffusive excursions and conservative (by up to sqrt(blocks)) for caged ones, whose
successive displacements anti-correlate. Units m s-1,
positive along +x (the top wall's motion).
"""
from __future__ import annotations

import math

import numpy as np

from pipeline.coarse_graining import structure
from pipeline.coarse_graining.kernels import Kernel
from pipeline.dumps.reader import Dump


#: Largest step along x (fraction of the cell length) between two snapshots a grain may make to be tracked.
UNWRAP_LIMIT = 0.25
#: Largest share of the kernel weight at a height that untracked grains may carry: above it the
#: field is not defined there (NaN), since leaving the fast grains out would bias it low.
UNTRACKED_WEIGHT_LIMIT = 0.01


class DisplacementError(ValueError):
    """The snapshots cannot give displacements (grains change between snapshots, or jump)."""


def grain_tracks(particles: Dump, snapshots: np.ndarray, body_types: tuple[int, ...] = (1,)
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Unwrapped x (m) of every body grain at every chosen snapshot, their z (m), masses (kg) and
    whether each could be tracked (no step above ``UNWRAP_LIMIT`` of the cell between snapshots).

    Returns ``(x, z, m, tracked)`` with ``x`` and ``z`` of shape (snapshots, grains). Grains are
    matched by id (dumps need not be sorted).
    """
    ids0 = None
    xs, zs, mass = [], [], None
    i_id, i_type, i_x, i_z, i_m = (particles.index(c) for c in ("id", "type", "x", "z", "mass"))
    for s in snapshots:
        rows = particles.data[particles.offsets[s]:particles.offsets[s + 1]]
        rows = rows[np.isin(rows[:, i_type], body_types)]
        rows = rows[np.argsort(rows[:, i_id], kind="stable")]
        if ids0 is None:
            ids0, mass = rows[:, i_id], rows[:, i_m]
        elif rows.shape[0] != ids0.size or not np.array_equal(rows[:, i_id], ids0):
            raise DisplacementError(f"{', '.join(particles.sources)}: the body grains differ between snapshots "
                                    f"(step {int(particles.timesteps[s])}): displacements need the same grains")
        xs.append(rows[:, i_x])
        zs.append(rows[:, i_z])
    x, z = np.array(xs), np.array(zs)
    lx = float(particles.boxes[snapshots[0]][0, 1] - particles.boxes[snapshots[0]][0, 0])
    step = np.diff(x, axis=0)
    step -= lx * np.round(step / lx)
    # A grain that moves more than a quarter cell between two snapshots cannot be unwrapped with
    # confidence (the minimum image is ambiguous near half a cell): it is not tracked.
    tracked = np.all(np.abs(step) <= UNWRAP_LIMIT * lx, axis=0) if step.size else np.ones(x.shape[1], dtype=bool)
    unwrapped = np.concatenate([x[:1], x[:1] + np.cumsum(step, axis=0)]) if step.size else x
    return unwrapped, z, mass, tracked


def _profile(v: np.ndarray, zbar: np.ndarray, m: np.ndarray, kernel: Kernel, z_grid: np.ndarray) -> np.ndarray:
    """Mass-weighted kernel average of per-grain values on ``z_grid`` (nan where no grain is near)."""
    w = kernel.pdf(z_grid[:, None] - zbar[None, :]) * m[None, :]
    total = w.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, (w @ v) / np.where(total > 0, total, 1.0), np.nan)


def displacement_velocity(particles: Dump, snapshots: np.ndarray, times: np.ndarray, kernel: Kernel,
                          z_grid: np.ndarray, blocks: int) -> tuple[np.ndarray, np.ndarray]:
    """``u_x_disp`` and its standard error on ``z_grid`` (module docstring); ``times`` (s) of the snapshots."""
    snapshots = np.asarray(snapshots)
    if snapshots.size < 2:
        raise DisplacementError("displacements need at least two snapshots in the window")
    x, z, m, tracked = grain_tracks(particles, snapshots)
    duration = float(times[-1] - times[0])
    if not duration > 0:
        raise DisplacementError("the averaging window has zero duration")
    zbar = z.mean(axis=0)
    weight = kernel.pdf(z_grid[:, None] - zbar[None, :]) * m[None, :]
    with np.errstate(invalid="ignore", divide="ignore"):
        untracked = (weight[:, ~tracked].sum(axis=1)) / weight.sum(axis=1)
    undefined = ~(untracked <= UNTRACKED_WEIGHT_LIMIT)
    x, z, m = x[:, tracked], z[:, tracked], m[tracked]
    u = _profile((x[-1] - x[0]) / duration, z.mean(axis=0), m, kernel, z_grid)
    u[undefined] = np.nan
    used = min(int(blocks), snapshots.size - 1)
    if used < 2:
        return u, np.full_like(u, np.nan)
    edges = np.linspace(0, snapshots.size - 1, used + 1).round().astype(int)
    parts = []
    for a, b in zip(edges[:-1], edges[1:]):
        dt = float(times[b] - times[a])
        parts.append(_profile((x[b] - x[a]) / dt, z[a:b + 1].mean(axis=0), m, kernel, z_grid))
    parts = np.array(parts)
    err = parts.std(axis=0, ddof=1) / math.sqrt(used)
    err[undefined] = np.nan
    return u, err


def displacement_structural_error(particles: Dump, snapshots: np.ndarray, times: np.ndarray, kernel: Kernel,
                                  z_grid: np.ndarray, d: float, bulk: np.ndarray) -> tuple[np.ndarray, float]:
    """The error of ``u_x_disp`` from the creep's frozen structure: patches of the cell as replicas
    (:func:`pipeline.coarse_graining.structure.mean_field_error`; grains placed by their position at
    the window's start). Returns the error on ``z_grid`` (m s-1) and the area exponent used."""
    snapshots = np.asarray(snapshots)
    x, z, m, tracked = grain_tracks(particles, snapshots)
    first = particles.rows(int(snapshots[0]))
    i_id, i_type, i_y = (particles.index(c) for c in ("id", "type", "y"))
    first = first[first[:, i_type] == 1]
    first = first[np.argsort(first[:, i_id], kind="stable")]
    duration = float(times[-1] - times[0])
    box = particles.boxes[int(snapshots[0])]
    v = (x[-1] - x[0]) / duration
    err, alpha, _ = structure.mean_field_error(np.mod(x[0] - box[0, 0], box[0, 1] - box[0, 0]) + box[0, 0], first[:, i_y],
                                               z.mean(axis=0), m * tracked, v, box, kernel, z_grid, d, bulk)
    return err, alpha
