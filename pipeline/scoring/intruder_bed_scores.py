"""The intruder bed scored like a planar case (issue 55, item 4): its x-averaged velocity profile
and its top wall's shear stress, each model's own 2D solve against the DEM.

In the periodic cell the x-average of the steady momentum balance is the planar one with the
rod's push added below the rod: the x-averaged sigma_xz is the top wall's stress above the rod and
that plus F / (L_x L_y) below it. So the bed's x-averaged profile and its wall stress say whether a
model carries the push through the bed as the DEM does, apart from the rod's own neighbourhood
(``intruder_field_scores``). Two scores per model over the scenes (rows of ``scores.csv``):

- ``intruder_bed_velocity_rmse``: RMS over z of (u_model(z) - u_DEM(z)) / V, u the x-averaged
  velocity along x: the DEM's ``fields/{case}/{run}.nc`` ``u_x`` (the grains' x-average, rod and wall
  grains left out), the model's ``model_fields/{case}/{model}/{scene}.nc`` ``u_x`` averaged over the
  material cells of each row (the rod's cells left out) and interpolated onto the DEM's z; points
  between the contact planes, at least the DEM kernel's width w from each;
- ``intruder_bed_wall_stress_rel_err``: |tau_model / tau_DEM - 1|, tau_DEM the top wall's
  ``wall_top_shear_stress`` (the fields' attribute: |<f_x>| / A over the production), tau_model the
  x-average of the model's |sigma_xz| on its top row of cells (the wall's stress: no push acts
  above the rod).

A model's score over scenes is the RMS of its scenes' (each scene weighs the same). DEM uncertainty
as the field scores': the mean of the scene's replicas plus their deviations with Gaussian
weights (n - 1 degrees of freedom); with one replica its stated errors (``u_x_err``, uncorrelated
along z: an underestimate, said so by ``dem_dof`` = inf). ``dem_noise``: the metric between two
replicas. u_input and u_num are not known: the draws and the grid study keep speeds, not fields.

Written by the scores rule: ``python -m pipeline.scoring scores ... --intruder-fields
RESULTS/fields/intruder/*.nc --intruder-model-fields RESULTS/model_fields/intruder/MODEL ...
--intruder-bed-out RESULTS/validation/intruder_bed.csv``.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from pipeline.common.config import derived_seed
from pipeline.scoring.intruder_field_scores import (CASE, FieldScores, _row, model_fields_files, pool_scenes,
                                                    scene_of_run)
from pipeline.scoring.uncertainty import finite_sd

VELOCITY = "intruder_bed_velocity_rmse"
WALL_STRESS = "intruder_bed_wall_stress_rel_err"
METRICS = (VELOCITY, WALL_STRESS)


@dataclass
class DemBed:
    """One scene's DEM bed: the x-averaged u_x on the scored z (replicas on the first's grid) and
    the top wall's shear stress per replica, with their resamples."""

    name: str
    z: np.ndarray
    u: list[np.ndarray]
    u_mean: np.ndarray
    u_resamples: np.ndarray   # (B, points)
    tau: np.ndarray           # per replica (Pa)
    tau_mean: float
    tau_resamples: np.ndarray  # (B,)
    dof: float
    wall_speed: float


def dem_bed(name: str, files: list[Path], n_resamples: int, seed: int) -> DemBed:
    """The DEM bed of one scene from its replicas' x-averaged fields files (module docstring)."""
    datasets = [xr.load_dataset(f) for f in sorted(files, key=lambda p: Path(p).stem)]
    ref = datasets[0]
    w = float(ref.attrs["width"])
    lo, hi = float(ref.attrs["z_bottom_contact_plane"]), float(ref.attrs["z_top_contact_plane"])
    z = ref["z"].values
    keep = (z >= lo + w) & (z <= hi - w)
    zk = z[keep]
    u = [np.interp(zk, ds["z"].values, ds["u_x"].values) for ds in datasets]
    tau = np.array([float(ds.attrs.get("wall_top_shear_stress", math.nan)) for ds in datasets])
    n = len(datasets)
    rng = np.random.default_rng(derived_seed(seed, "scoring", "intruder_bed", name))
    u_mean = np.mean(u, axis=0)
    tau_mean = float(np.nanmean(tau)) if np.isfinite(tau).any() else math.nan
    if n >= 2:
        g = rng.standard_normal((n_resamples, n))
        dev = np.array(u) - u_mean[None, :]
        u_res = u_mean[None, :] + g @ dev / math.sqrt(n * (n - 1))
        tau_res = tau_mean + g @ (tau - tau_mean) / math.sqrt(n * (n - 1))
        dof = float(n - 1)
    else:
        err = np.interp(zk, ref["z"].values, ref["u_x_err"].values)
        u_res = u_mean[None, :] + err[None, :] * rng.standard_normal((n_resamples, zk.size))
        tau_err = float(ref.attrs.get("wall_top_shear_stress_err", math.nan))
        tau_res = tau_mean + tau_err * rng.standard_normal(n_resamples)
        dof = math.inf
    return DemBed(name, zk, u, u_mean, u_res, tau, tau_mean, tau_res, dof, float(ref.attrs["wall_speed"]))


def model_bed(ds: xr.Dataset, z: np.ndarray) -> tuple[np.ndarray, float]:
    """A model's x-averaged u_x (m s-1) on the DEM's ``z`` (NaN outside its cell) and its top-wall
    shear stress (Pa): the x-average of |sigma_xz| on its top row of cells."""
    solid = ds["solid"].transpose("x", "z").values.astype(bool)
    ux = np.where(solid, np.nan, ds["u_x"].transpose("x", "z").values.astype(float))
    with np.errstate(invalid="ignore"):
        profile = np.nanmean(ux, axis=0)
    mz = ds["z"].values
    u = np.interp(z, mz, profile, left=np.nan, right=np.nan)
    sxz = np.abs(ds["sigma_xz"].transpose("x", "z").values.astype(float))
    top = int(np.argmax(mz))
    tau = float(np.nanmean(sxz[:, top]))
    return u, tau


def _velocity(u_model: np.ndarray, u_dem: np.ndarray, wall_speed: float) -> np.ndarray | float:
    ok = np.isfinite(u_model)
    value = np.sqrt(np.mean((u_model[ok] - np.atleast_2d(u_dem)[..., ok]) ** 2, axis=-1)) / wall_speed
    return float(value[0]) if np.ndim(u_dem) == 1 else value


def _stress(tau_model: float, tau_dem: np.ndarray | float) -> np.ndarray | float:
    return np.abs(tau_model / np.asarray(tau_dem) - 1.0) if np.ndim(tau_dem) else abs(tau_model / tau_dem - 1.0)


def score_intruder_bed(field_files: list[Path], model_dirs: list[Path], settings: Any = None,
                       case: str = CASE) -> FieldScores:
    """The bed scores of every model (module docstring): ``field_files`` fields/{case}/*.nc (the
    x-averaged ones), ``model_dirs`` model_fields/{case}/{model} folders."""
    n_resamples = int(getattr(settings, "dem_resamples", 200))
    seed = int(getattr(settings, "seed", 0))
    models = model_fields_files(model_dirs)
    by_scene: dict[str, list[Path]] = {}
    for f in field_files:
        by_scene.setdefault(scene_of_run(Path(f).stem), []).append(Path(f))
    scenes = sorted(s for s in by_scene if any(s in files for files in models.values()))
    dem = {s: dem_bed(s, by_scene[s], n_resamples, seed) for s in scenes}
    rows, scene_rows, samples = [], [], {}
    for model in sorted(models):
        for metric in METRICS:
            terms = np.full(len(scenes), np.nan)
            terms_dem = np.full((n_resamples, len(scenes)), np.nan)
            noise_all: list[float] = []
            n_grid = 0
            for k, s in enumerate(scenes):
                path = models[model].get(s)
                if path is None:
                    continue
                bed = dem[s]
                with xr.open_dataset(path) as ds:
                    u, tau = model_bed(ds, bed.z)
                    cells = int(ds.attrs.get("nx", 0)) * int(ds.attrs.get("nz", 0))
                if metric == VELOCITY:
                    if not np.isfinite(u).any():
                        continue
                    value, resampled = _velocity(u, bed.u_mean, bed.wall_speed), _velocity(u, bed.u_resamples, bed.wall_speed)
                    pairs = [_velocity(a, b, bed.wall_speed) for a, b in itertools.combinations(bed.u, 2)]
                    used = int(np.isfinite(u).sum())
                else:
                    if not (math.isfinite(tau) and math.isfinite(bed.tau_mean)):
                        continue
                    value, resampled = _stress(tau, bed.tau_mean), _stress(tau, bed.tau_resamples)
                    pairs = [_stress(a, b) for a, b in itertools.combinations(bed.tau, 2)
                             if math.isfinite(a) and math.isfinite(b)]
                    used = 1
                n_grid = max(n_grid, cells)
                terms[k], terms_dem[:, k] = value, resampled
                noise_all += [float(p) for p in pairs]
                scene_rows.append(_row(case, model, metric, float(value), finite_sd(resampled), [float(p) for p in pairs],
                                       cells, bed.dof, s)
                                  | {"scene": s, "window_points": used, "replicas": len(bed.u), "dem_err_rms": math.nan})
            pooled = pool_scenes(scenes, terms, terms_dem, {s: dem[s].dof for s in scenes})
            if pooled is None:
                continue
            full, one, covered, dof = pooled
            samples[(case, model, metric)] = full
            rows.append(_row(case, model, metric, one.value, one.u_dem, noise_all, n_grid, dof, " ".join(covered)))
    return FieldScores(rows, scene_rows, samples)

