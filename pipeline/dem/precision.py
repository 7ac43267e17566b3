"""When a run's production has averaged enough: the precision of the fields it will be scored on.

After each production chunk the run measures, from the chunks committed so far, the standard
errors of what the scores read (``dem.precision`` in the config names the targets):

- ``u_x_over_v``: the largest standard error of ``u_x / V`` (V the top wall's speed) over 1 d
  bins of the bulk (``bulk_margin_over_d`` from each wall's mean height);
- ``nu``: the standard error of the bulk's mean solid fraction (grain volumes counted by centre):
  the rheometer's nu(I) point; a profile's bin-to-bin structure is frozen in the packing and does
  not average out in time, so it is no stopping criterion;
- ``mu``: the standard error of the top wall's stress ratio ``|ftop_x| / ftop_z`` from the wall
  series: the scored friction of a rheometer state; with gravity, the error of the part of the
  scored profile ``mu(z) = tau / p(z)`` that ``tau`` sets (uniform in steady flow), the largest
  at the top where ``p`` is least (the replicas' mean offsets of mu(z), 0.011-0.023, were most
  of the targeted design's higher mu_rmse noise, docs/dem_cost.md);
- ``log_speed`` (gravity): the largest error of ``log10`` of the displacement creep speed from
  the top wall down to ``log_speed_depth_over_d`` below it, the depth to which a creeping case's
  decay is scored; a bin whose speed is not resolved (``<= 2`` errors) counts as unmet.

The errors are batch means with one chunk per batch (each chunk is ``chunk_strain`` of wall
displacement over depth, several correlation times of the wall's vertical oscillation), so the
measure needs at least three chunks. A target is met when the error's upper confidence bound
(:func:`error_bound_factor`) is under it, not the estimate itself: from 3 batches the estimate
is below 0.42 of the true error 16 % of the time, and a run that stopped on such a low estimate
was less precise than its target (shear_gravity r1 of the 2026-12-01 night, docs/dem_cost.md). It is a stopping rule, not the scored error: the
coarse-graining computes the fields' errors afresh, with the correlation time checked. The test
reads only committed chunks, so a resumed run takes the same decisions and stops at the same
chunk.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
# scipy.special's chi-squared quantile (scipy.stats.chi2.ppf bit for bit) spares each DEM job the
# import of scipy.stats (about 0.55 CPU s).
from scipy import special

from pipeline.dumps.reader import read_particles

#: Fewest chunks whose scatter is read as an error (two degrees of freedom at least).
MIN_BLOCKS = 3
#: Confidence of the upper bound an error must be under to meet its target (one-sided: 1 sigma).
ERROR_BOUND_CONFIDENCE = 0.84
#: Bin thickness, in d.
BIN_OVER_D = 1.0
#: Distance (in d) from each wall's mean height beyond which a bin is bulk: the scores' and the
#: calibration's default margin (a DEM run's config holds no calibration section to read it from).
BULK_MARGIN_OVER_D = 3.0


@dataclass(frozen=True)
class ChunkMeans:
    """Per-chunk means of one run's fields in bins of height (m) measured from the bottom wall.

    ``u_x_over_v``, ``nu``, ``u_disp_over_v`` have shape (chunks, bins); ``depth`` is each bin
    centre's depth below the top wall (m); ``bulk`` marks bins ``bulk_margin`` from both walls.
    """

    u_x_over_v: np.ndarray
    nu: np.ndarray
    u_disp_over_v: np.ndarray
    depth: np.ndarray
    bulk: np.ndarray


def standard_error(blocks: np.ndarray) -> np.ndarray:
    """Batch-means standard error of the mean over axis 0 (NaN with fewer than ``MIN_BLOCKS``)."""
    blocks = np.asarray(blocks, dtype=float)
    if blocks.shape[0] < MIN_BLOCKS:
        return np.full(blocks.shape[1:], np.nan)
    return blocks.std(axis=0, ddof=1) / math.sqrt(blocks.shape[0])


def error_bound_factor(blocks: int, confidence: float = ERROR_BOUND_CONFIDENCE) -> float:
    """Factor from a batch-means standard error over ``blocks`` batches to its upper bound at
    ``confidence``: ``sqrt(k / chi2_{1-confidence}(k))``, k = blocks - 1 degrees of freedom (the
    sample variance of normal batch means is chi-squared with k dof). 2.39 for 3 batches, 1.89 for 4,
    1.68 for 5, 1.42 for 8."""
    if blocks < 2:
        raise ValueError(f"an error needs 2 batches at the least, got {blocks}")
    dof = blocks - 1
    return math.sqrt(dof / float(2.0 * special.gammaincinv(0.5 * dof, 1.0 - confidence)))  # chi2 quantile at 1 - confidence


def chunk_means(dump_paths: list[Path], d: float, dt: float, wall_speed: float, bulk_margin: float) -> ChunkMeans:
    """Bin means of every production chunk's particle dump (``id type x z vx radius`` read);
    ``dt`` (s) the time step, ``wall_speed`` (m/s) the speed the velocities are scaled by.

    The bins are fixed from the first chunk's mean wall heights (types 2 and 3), so every chunk
    is averaged on the same bins.
    """
    ux, nu, ud = [], [], []
    edges = None
    for path in dump_paths:
        dump = read_particles(path)
        i_id, i_t, i_x, i_z, i_vx, i_r = (dump.index(c) for c in ("id", "type", "x", "z", "vx", "radius"))
        box = dump.boxes[0]
        lx, area = box[0, 1] - box[0, 0], (box[0, 1] - box[0, 0]) * (box[1, 1] - box[1, 0])
        rows = [dump.rows(s) for s in range(len(dump))]
        if edges is None:
            z_bot = float(np.mean([r[r[:, i_t] == 2, i_z].mean() for r in rows]))
            z_top = float(np.mean([r[r[:, i_t] == 3, i_z].mean() for r in rows]))
            n_bins = max(1, int((z_top - z_bot) / (BIN_OVER_D * d)))
            edges = np.linspace(z_bot, z_top, n_bins + 1)
            centres = 0.5 * (edges[1:] + edges[:-1])
            depth = z_top - centres
            bulk = (centres - z_bot >= bulk_margin) & (depth >= bulk_margin)
        n_bins = edges.size - 1
        vx_sum, count, volume = np.zeros(n_bins), np.zeros(n_bins), np.zeros(n_bins)
        body = []
        for r in rows:
            g = r[r[:, i_t] == 1]
            g = g[np.argsort(g[:, i_id], kind="stable")]
            body.append(g)
            b = np.clip(np.searchsorted(edges, g[:, i_z]) - 1, 0, n_bins - 1)
            vx_sum += np.bincount(b, g[:, i_vx], n_bins)
            count += np.bincount(b, minlength=n_bins)
            volume += np.bincount(b, 4.0 / 3.0 * np.pi * g[:, i_r] ** 3, n_bins)
        with np.errstate(invalid="ignore", divide="ignore"):
            ux.append(vx_sum / count / wall_speed)
        nu.append(volume / (len(rows) * area * np.diff(edges)))
        # Displacement speed: minimum-image steps between snapshots, summed; grains binned at
        # their mean height over the chunk.
        x = np.array([g[:, i_x] for g in body])
        step = np.diff(x, axis=0)
        step -= lx * np.round(step / lx)
        zbar = np.mean([g[:, i_z] for g in body], axis=0)
        duration = float(dump.timesteps[-1] - dump.timesteps[0]) * dt
        b = np.clip(np.searchsorted(edges, zbar) - 1, 0, n_bins - 1)
        with np.errstate(invalid="ignore", divide="ignore"):
            ud.append(np.bincount(b, step.sum(axis=0), n_bins) / np.bincount(b, minlength=n_bins) / duration / wall_speed)
    return ChunkMeans(np.array(ux), np.array(nu), np.array(ud), depth, bulk)


def measure(means: ChunkMeans, d: float, stress_ratio_blocks: np.ndarray | None,
            targets: dict[str, float], gravity: bool) -> dict[str, Any]:
    """The errors reached and whether each target in ``targets`` is met.

    ``stress_ratio_blocks``: per-chunk mean wall stress ratio, or None.
    Returns ``{"blocks", "reached": {name: error}, "bound_factor", "bound": {name: upper bound},
    "met": {name: bool (bound <= target)}, "all_met"}``.
    """
    reached: dict[str, float] = {}
    blocks = means.nu.shape[0]
    if blocks < MIN_BLOCKS:
        return {"blocks": blocks, "reached": {}, "bound": {}, "met": {}, "all_met": False}
    if "u_x_over_v" in targets:
        reached["u_x_over_v"] = float(np.nanmax(standard_error(means.u_x_over_v[:, means.bulk])))
    if "nu" in targets:
        reached["nu"] = float(standard_error(means.nu[:, means.bulk].mean(axis=1)[:, None])[0])
    if "mu" in targets and stress_ratio_blocks is not None:
        reached["mu"] = float(standard_error(np.asarray(stress_ratio_blocks)[:, None])[0])
    if "log_speed" in targets and gravity:
        speed = means.u_disp_over_v
        mean, err = np.nanmean(speed, axis=0), standard_error(speed)
        scored = means.depth <= targets["log_speed_depth_over_d"] * d
        with np.errstate(invalid="ignore", divide="ignore"):
            log_err = np.where(mean[scored] > 2.0 * err[scored], err[scored] / (mean[scored] * math.log(10.0)), np.inf)
        reached["log_speed"] = float(np.max(log_err)) if log_err.size else math.inf
    return judge(reached, targets, blocks)


def judge(reached: dict[str, float], targets: dict[str, float], blocks: int,
          bound: dict[str, float] | None = None) -> dict[str, Any]:
    """Each error's upper bound (``reached`` x :func:`error_bound_factor` of ``blocks``, unless
    ``bound`` gives them) against its target; ``all_met`` needs at least one target."""
    factor = error_bound_factor(blocks)
    if bound is None:
        bound = {name: value * factor for name, value in reached.items()}
    met = {name: bool(bound[name] <= targets[name]) for name in reached}
    return {"blocks": blocks, "reached": reached, "bound_factor": factor, "bound": bound, "met": met,
            "all_met": bool(met) and all(met.values())}
