"""The intruder models' 2D fields scored against the DEM's x-z fields around the rod (issue 55, item 4).

Per model and scene, the RMS over the points of a window around the rod of
- ``intruder_field_velocity_rmse``: |u_model - u_dem| / V, u = (u_x_rel, u_z) the velocity
  relative to the rod (each DEM replica relative to its own rod's mean speed, the model's to its
  rod's speed), V the top wall's speed;
- ``intruder_field_mu_rmse``: mu_model - mu_dem, mu = |sigma_xz| / p (the DEM fields' ``mu``;
  the model's ``mu_xz``, p its pressure, the DEM's trace / 3);
- ``intruder_field_nu_rmse``: nu_model - nu_dem, for the models with a solid fraction.

The points: the DEM grid of the scene's first replica (the one whose rod the model's scene has),
within ``WINDOW_OVER_ROD`` rod diameters of the rod's axis along x and z, outside the rod by the
DEM's kernel width w (within w of its surface the kernel straddles the rod, whose grains are not
coarse-grained: the solid fraction there falls to the rod's void), and at least w from the walls'
contact planes (taken as the wall grains' centres plus d / 2); the model interpolated onto them
(bilinear, periodic in x; a point whose stencil reaches into the model's rod is left out). The DEM
reference is the mean of the scene's replicas (runs of the same name up to ``-r<k>``) on that grid.

Uncertainty of the DEM mean (``u_dem``, resampled ``dem_resamples`` times, the same resamples for
every model so that the verdict's differences are paired): with n >= 2 replicas, the mean plus the
replicas' deviations with Gaussian weights, mean + sum_i g_i (r_i - mean) / sqrt(n (n - 1)): the
covariance of the mean estimated from the replicas' scatter, the whole field's correlation
included, n - 1 degrees of freedom; with one replica, the mean plus its stated errors (``_err``:
block averages in time) times a unit Gaussian field correlated over the kernel width (infinite
degrees of freedom, as the planar scores' single replica). ``dem_noise``: the metric between two
replicas (one as the model), the mean over the pairs. ``u_input`` and ``u_num`` are not known
here: the draws and the grid study keep their speeds, not their fields.

A model's score over scenes is the RMS of its scenes' scores (each scene weighs the same, as the
depth sweep's depths); ``points`` names the scenes it covers, and its per-scene terms let the
verdict compare two models on the scenes both cover.

Usage: ``python -m pipeline.scoring.intruder_field_scores --fields-xz RESULTS/fields_xz/intruder/*.nc
--model-fields RESULTS/model_fields/intruder/MODEL ... [--config C] --out RESULTS/validation/intruder_fields.csv``
"""
from __future__ import annotations

import argparse
import itertools
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from scipy import ndimage
from scipy.interpolate import RegularGridInterpolator

from pipeline.common import atomic
from pipeline.common.config import derived_seed, load_config
from pipeline.scoring.score_table import COLUMNS, ScoringSettings
from pipeline.scoring.uncertainty import ScoreSamples, finite_sd

CASE = "intruder"
#: Half-width of the scored window around the rod's axis, along x and along z, in rod diameters.
WINDOW_OVER_ROD = 3.0
#: The metrics: name -> the model's variables, the DEM's (same order), and whether the difference
#: is a velocity over V (the others are dimensionless differences).
METRICS: dict[str, tuple[tuple[str, ...], tuple[str, ...], bool]] = {
    "intruder_field_velocity_rmse": (("u_x_rel", "u_z"), ("u_x_rel", "u_z"), True),
    "intruder_field_mu_rmse": (("mu_xz",), ("mu",), False),
    "intruder_field_nu_rmse": (("nu",), ("nu",), False),
}
#: The DEM variables resampled (each with its ``_err``; u_x_rel's is u_x's).
DEM_VARIABLES = ("u_x_rel", "u_z", "mu", "nu")
#: Columns of the per-scene table beside scores.csv's: ``dem_err_rms`` is the RMS over the window of
#: the DEM mean's standard error (the metric's variables in quadrature; over V for the velocity), the
#: score a model equal to the DEM's true field would get on average from the DEM's noise alone.
SCENE_COLUMNS = ["scene", "window_points", "replicas", "dem_err_rms"]
_REPLICA = re.compile(r"^(?P<scene>.+)-r(?P<k>\d+)$")


def scene_of_run(run: str) -> str:
    """A run's scene: its name without ``-r<k>``."""
    m = _REPLICA.match(run)
    return m.group("scene") if m else run


@dataclass
class DemScene:
    """One scene's DEM reference on its window's points (flat arrays over the points)."""

    name: str
    reference: str
    x: np.ndarray                     # from the rod's axis (m)
    z: np.ndarray                     # the DEM's height (m)
    mean: dict[str, np.ndarray]
    error: dict[str, np.ndarray]      # the mean's standard error on the points
    resamples: dict[str, np.ndarray]  # variable -> (B, points)
    replicas: list[dict[str, np.ndarray]]
    dof: float
    wall_speed: float
    rod_z: float
    rod_diameter: float
    grid_x: np.ndarray = field(repr=False, default_factory=lambda: np.array([]))
    grid_z: np.ndarray = field(repr=False, default_factory=lambda: np.array([]))
    window: np.ndarray = field(repr=False, default_factory=lambda: np.array([]))

    @property
    def n_replicas(self) -> int:
        return len(self.replicas)


def _dem_variable(ds: xr.Dataset, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(values, standard errors) of a DEM variable on (x, z); u_x_rel from u_x and the rod's speed
    where the file lacks it, its error u_x's."""
    if name == "u_x_rel":
        values = ds["u_x_rel"].values if "u_x_rel" in ds else ds["u_x"].values - float(ds.attrs["rod_speed"])
        return np.asarray(values, dtype=float), np.asarray(ds["u_x_err"].values, dtype=float)
    return np.asarray(ds[name].values, dtype=float), np.asarray(ds[f"{name}_err"].values, dtype=float)


def _on_grid(ds: xr.Dataset, values: np.ndarray, x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """A replica's (x, z) field on another replica's grid (the same grid: as is)."""
    gx, gz = ds["x"].values, ds["z"].values
    if gx.shape == x.shape and gz.shape == z.shape and np.allclose(gx, x) and np.allclose(gz, z):
        return values
    interp = RegularGridInterpolator((gx, gz), values, bounds_error=False, fill_value=np.nan)
    xx, zz = np.meshgrid(x, z, indexing="ij")
    return interp(np.column_stack([xx.ravel(), zz.ravel()])).reshape(xx.shape)


def rod_of(ds: xr.Dataset) -> tuple[float, float, float]:
    """(x, z, diameter) of the rod's axis in a fields_xz file (m)."""
    z = float(ds.attrs["z_top_wall"]) - float(ds.attrs["rod_depth_over_d"]) * float(ds.attrs["d"])
    return float(ds.attrs["rod_centre_x"]), z, float(ds.attrs["rod_diameter"])


def window_mask(ds: xr.Dataset, window_over_rod: float = WINDOW_OVER_ROD) -> np.ndarray:
    """The scored points of a fields_xz grid (x, z): module docstring."""
    xc, zc, diameter = rod_of(ds)
    lx = float(np.atleast_1d(ds.attrs["cell"])[0])
    d, w = float(ds.attrs["d"]), float(ds.attrs["width"])
    xx, zz = np.meshgrid(ds["x"].values, ds["z"].values, indexing="ij")
    dx = (xx - xc + 0.5 * lx) % lx - 0.5 * lx
    dz = zz - zc
    half = window_over_rod * diameter
    lo, hi = float(ds.attrs["z_bottom_wall"]) + 0.5 * d + w, float(ds.attrs["z_top_wall"]) - 0.5 * d - w
    return (np.abs(dx) <= half) & (np.abs(dz) <= half) & (np.hypot(dx, dz) > 0.5 * diameter + w) & (zz >= lo) & (zz <= hi)


def correlated_field(rng: np.random.Generator, n_samples: int, shape: tuple[int, int], spacing: tuple[float, float],
                     length: float) -> np.ndarray:
    """Unit-variance Gaussian fields (samples, *shape) correlated over ``length``: white noise
    filtered by a Gaussian of that width, periodic along the first axis (x), on a grid padded by
    four widths along the second (z) and cropped, so every point has the filter's full support."""
    sigma = tuple(max(length / max(h, 1e-300), 1e-6) for h in spacing)
    pad = int(math.ceil(4.0 * sigma[1]))
    padded = (shape[0], shape[1] + 2 * pad)
    delta = np.zeros(padded)
    delta[shape[0] // 2, padded[1] // 2] = 1.0
    norm = math.sqrt(float(np.sum(ndimage.gaussian_filter(delta, sigma, mode=("wrap", "constant")) ** 2)))
    out = np.empty((n_samples, *shape))
    for b in range(n_samples):
        noise = ndimage.gaussian_filter(rng.standard_normal(padded), sigma, mode=("wrap", "constant"))
        out[b] = noise[:, pad:pad + shape[1]] / norm
    return out


def dem_scene(name: str, files: list[Path], reference: str | None = None, n_resamples: int = 200, seed: int = 0,
              window_over_rod: float = WINDOW_OVER_ROD) -> DemScene:
    """The DEM reference of one scene from its replicas' fields_xz files (module docstring):
    ``reference`` the run whose grid and rod the points are taken from (default: the first)."""
    datasets = {Path(f).stem: xr.load_dataset(f) for f in sorted(files, key=lambda p: Path(p).stem)}
    ref_name = reference if reference in datasets else next(iter(datasets))
    ref = datasets[ref_name]
    gx, gz = ref["x"].values, ref["z"].values
    mask = window_mask(ref, window_over_rod)
    xc, zc, diameter = rod_of(ref)
    lx = float(np.atleast_1d(ref.attrs["cell"])[0])
    order = [ref_name] + [k for k in datasets if k != ref_name]
    full: list[dict[str, np.ndarray]] = []
    errors: dict[str, np.ndarray] = {}
    for k in order:
        ds = datasets[k]
        one = {}
        for var in DEM_VARIABLES:
            values, err = _dem_variable(ds, var)
            one[var] = _on_grid(ds, values, gx, gz)
            if k == ref_name:
                errors[var] = err
        full.append(one)
    n = len(full)
    mean_full = {v: np.mean([r[v] for r in full], axis=0) for v in DEM_VARIABLES}
    rng = np.random.default_rng(derived_seed(seed, "scoring", "intruder_fields", name))
    resamples = {}
    if n >= 2:
        error = {v: np.std([r[v][mask] for r in full], axis=0, ddof=1) / math.sqrt(n) for v in DEM_VARIABLES}
        g = rng.standard_normal((n_resamples, n))
        for v in DEM_VARIABLES:
            dev = np.array([r[v][mask] - mean_full[v][mask] for r in full])  # (n, points)
            resamples[v] = mean_full[v][mask][None, :] + g @ dev / math.sqrt(n * (n - 1))
        dof = float(n - 1)
    else:
        width = float(ref.attrs["width"])
        spacing = (float(np.mean(np.diff(gx))), float(np.mean(np.diff(gz))))
        for v in DEM_VARIABLES:
            eps = correlated_field(rng, n_resamples, mask.shape, spacing, width)
            sigma = np.where(np.isfinite(errors[v]), errors[v], 0.0)
            resamples[v] = mean_full[v][mask][None, :] + sigma[mask][None, :] * eps[:, mask]
        dof = math.inf
        error = {v: errors[v][mask] for v in DEM_VARIABLES}
    xx, zz = np.meshgrid(gx, gz, indexing="ij")
    dx = (xx - xc + 0.5 * lx) % lx - 0.5 * lx
    return DemScene(name, ref_name, dx[mask], zz[mask], {v: mean_full[v][mask] for v in DEM_VARIABLES}, error, resamples,
                    [{v: r[v][mask] for v in DEM_VARIABLES} for r in full], dof, float(ref.attrs["wall_speed"]), zc,
                    diameter, gx, gz, mask)


def model_on_points(ds: xr.Dataset, x: np.ndarray, z: np.ndarray, variables: tuple[str, ...]) -> dict[str, np.ndarray]:
    """A model's fields file (``pipeline.models.intruder_fields``: x from the rod's axis, periodic
    with period ``cell``; z the DEM's) interpolated bilinearly onto the points (NaN outside its
    cell, and where the stencil reaches a NaN: the rod)."""
    mx, mz = ds["x"].values, ds["z"].values
    lx = float(ds.attrs["cell"])
    xp = np.concatenate([[mx[-1] - lx], mx, [mx[0] + lx]])
    xw = (x + 0.5 * lx) % lx - 0.5 * lx
    out = {}
    for v in variables:
        values = ds[v].transpose("x", "z").values.astype(float)
        padded = np.concatenate([values[-1:], values, values[:1]], axis=0)
        interp = RegularGridInterpolator((xp, mz), padded, bounds_error=False, fill_value=np.nan)
        out[v] = interp(np.column_stack([xw, z]))
    return out


def metric_values(metric: str, model: dict[str, np.ndarray], dem: dict[str, np.ndarray], wall_speed: float
                  ) -> tuple[np.ndarray | float, int]:
    """The metric (module docstring) of model values against DEM values on the same points: the
    DEM's arrays (points) or (samples, points); returns the value(s) and the number of points used
    (those where the model and the DEM mean are finite)."""
    m_vars, d_vars, velocity = METRICS[metric]
    sq = 0.0
    ok = np.ones(np.shape(model[m_vars[0]])[-1], bool)
    for mv, dv in zip(m_vars, d_vars):
        ok &= np.isfinite(model[mv])
        ok &= np.all(np.isfinite(np.atleast_2d(dem[dv])), axis=0)
    if not ok.any():
        return math.nan, 0
    for mv, dv in zip(m_vars, d_vars):
        sq = sq + (model[mv][..., ok] - dem[dv][..., ok]) ** 2
    value = np.sqrt(np.mean(sq, axis=-1))
    if velocity:
        value = value / wall_speed
    return (float(value) if np.ndim(value) == 0 else value), int(ok.sum())


def has_variables(ds: xr.Dataset, metric: str) -> bool:
    return all(v in ds for v in METRICS[metric][0])


@dataclass
class FieldScores:
    """``rows``: one per model and metric over its scenes (scores.csv's columns); ``scene_rows``:
    one per model, metric and scene (the same columns plus ``SCENE_COLUMNS``); ``samples``: the
    resamples of ``rows`` for the verdict, keyed (case, model, metric)."""

    rows: list[dict[str, Any]]
    scene_rows: list[dict[str, Any]]
    samples: dict[tuple[str, str, str], ScoreSamples]

    def table(self, columns: list[str]) -> pd.DataFrame:
        """Every row, the scenes' and the pooled ones (``scene`` "all"), as one frame."""
        pooled = [r | {"scene": "all", "window_points": math.nan, "replicas": math.nan, "dem_err_rms": math.nan}
                  for r in self.rows]
        return pd.DataFrame(self.scene_rows + pooled, columns=columns + SCENE_COLUMNS)


def model_fields_files(model_dirs: list[Path]) -> dict[str, dict[str, Path]]:
    """model -> scene -> fields file, from ``model_fields/intruder/{model}/`` folders."""
    return {Path(d).name: {p.stem: p for p in sorted(Path(d).glob("*.nc"))} for d in model_dirs}


def score_intruder_fields(dem_files: list[Path], model_dirs: list[Path], settings: Any = None,
                          window_over_rod: float = WINDOW_OVER_ROD, case: str = CASE) -> FieldScores:
    """The field scores of every model (module docstring). ``dem_files``: fields_xz/{case}/*.nc;
    ``model_dirs``: model_fields/{case}/{model} folders; ``settings``: ``ScoringSettings``
    (``dem_resamples``, ``seed``); ``case`` the rows' case."""
    n_resamples = int(getattr(settings, "dem_resamples", 200))
    seed = int(getattr(settings, "seed", 0))
    models = model_fields_files(model_dirs)
    by_scene: dict[str, list[Path]] = {}
    for f in dem_files:
        by_scene.setdefault(scene_of_run(Path(f).stem), []).append(Path(f))
    scenes = sorted(s for s in by_scene if any(s in files for files in models.values()))
    dem: dict[str, DemScene] = {}
    for s in scenes:
        reference = None
        for files in models.values():
            if s in files:
                with xr.open_dataset(files[s]) as ds:
                    reference = str(ds.attrs.get("run", "")) or None
                break
        dem[s] = dem_scene(s, by_scene[s], reference, n_resamples, seed, window_over_rod)
    noise = {(s, metric): _pair_values(dem[s], metric) for s in scenes for metric in METRICS}
    rows, scene_rows, samples = [], [], {}
    for model in sorted(models):
        for metric in METRICS:
            terms = np.full(len(scenes), np.nan)
            terms_dem = np.full((n_resamples, len(scenes)), np.nan)
            n_grid = 0
            for k, s in enumerate(scenes):
                path = models[model].get(s)
                if path is None:
                    continue
                with xr.open_dataset(path) as ds:
                    if not has_variables(ds, metric):
                        continue
                    m = model_on_points(ds, dem[s].x, dem[s].z, METRICS[metric][0])
                    cells = int(ds.attrs.get("nx", 0)) * int(ds.attrs.get("nz", 0))
                n_grid = max(n_grid, cells)
                value, used = metric_values(metric, m, dem[s].mean, dem[s].wall_speed)
                if used == 0:
                    continue
                resampled, _ = metric_values(metric, m, dem[s].resamples, dem[s].wall_speed)
                terms[k], terms_dem[:, k] = value, resampled
                pairs = noise[(s, metric)]
                scene_rows.append(_row(case, model, metric, value, finite_sd(resampled), pairs, cells, dem[s].dof, s)
                                  | {"scene": s, "window_points": used, "replicas": dem[s].n_replicas,
                                     "dem_err_rms": error_rms(dem[s], metric)})
            pooled = pool_scenes(scenes, terms, terms_dem, {s: dem[s].dof for s in scenes})
            if pooled is None:
                continue
            full, one, covered, dof = pooled
            samples[(case, model, metric)] = full
            pairs = [v for s in covered for v in noise[(s, metric)]]
            scene_means = [np.mean(noise[(s, metric)]) for s in covered if noise[(s, metric)]]
            row = _row(case, model, metric, one.value, one.u_dem, pairs, n_grid, dof, " ".join(covered))
            row["dem_noise"] = float(np.sqrt(np.mean(np.square(scene_means)))) if scene_means else math.nan
            rows.append(row)
    return FieldScores(rows, scene_rows, samples)


def pool_scenes(scenes: list[str], terms: np.ndarray, terms_dem: np.ndarray, dof_of: dict[str, float]
                ) -> tuple[ScoreSamples, ScoreSamples, list[str], float] | None:
    """A model's score over the scenes it covers (``terms`` finite): the RMS of their scores, with
    the per-scene terms kept for the verdict's paired comparisons. Returns (the samples over every
    scene, those over the covered ones, the covered scenes, the summed DEM degrees of freedom), or
    None where no scene is covered."""
    covered = [s for s, t in zip(scenes, terms) if np.isfinite(t)]
    if not covered:
        return None
    dofs = [dof_of[s] for s in covered]
    dof = float(sum(dofs)) if all(math.isfinite(x) for x in dofs) else math.inf
    full = ScoreSamples(math.nan, np.array([]), np.array([]), math.nan, dof, list(scenes), terms, terms_dem,
                        np.full((0, len(scenes)), np.nan), np.full(len(scenes), np.nan))
    return full, full.on_points(covered), covered, dof


def error_rms(scene: DemScene, metric: str) -> float:
    """The RMS over the scene's points of the DEM mean's standard error for ``metric`` (its
    variables in quadrature; over V for the velocity): ``SCENE_COLUMNS``."""
    _, d_vars, velocity = METRICS[metric]
    sq = sum(scene.error[v] ** 2 for v in d_vars)
    ok = np.isfinite(sq) & np.all([np.isfinite(scene.mean[v]) for v in d_vars], axis=0)
    if not ok.any():
        return math.nan
    value = float(np.sqrt(np.mean(sq[ok])))
    return value / scene.wall_speed if velocity else value


def _pair_values(scene: DemScene, metric: str) -> list[float]:
    """The metric between each pair of the scene's replicas (one as the model), finite ones only."""
    out = []
    for a, b in itertools.combinations(scene.replicas, 2):
        value, used = metric_values(metric, {mv: a[dv] for mv, dv in zip(*METRICS[metric][:2])}, b, scene.wall_speed)
        if used and math.isfinite(value):
            out.append(float(value))
    return out


def _row(case: str, model: str, metric: str, value: float, u_dem: float, pairs: list[float], n_grid: int, dof: float,
         points: str) -> dict[str, Any]:
    return {"case": case, "model": model, "metric": metric, "value": value,
            "dem_noise": float(np.mean(pairs)) if pairs else math.nan, "n_grid": n_grid, "solve_seconds": math.nan,
            "role": math.nan, "u_dem": u_dem, "u_input": math.nan, "u_num": math.nan, "u_val": u_dem, "dem_dof": dof,
            "draws_solved": 0, "draws_finite": math.nan, "u_input_method": "",
            "dem_noise_err": float(np.std(pairs, ddof=1) / math.sqrt(len(pairs))) if len(pairs) >= 2 else math.nan,
            "dem_noise_pairs": len(pairs), "points": points}


def main(argv: list[str] | None = None) -> int:

    parser = argparse.ArgumentParser(description="The intruder models' 2D fields against the DEM's around the rod.")
    parser.add_argument("--fields-xz", nargs="+", required=True, type=Path, help="fields_xz/intruder/RUN.nc files")
    parser.add_argument("--model-fields", nargs="+", required=True, type=Path,
                        help="model_fields/intruder/MODEL folders (python -m pipeline.models.intruder_fields)")
    parser.add_argument("--config", type=Path, help="the effective config (seed, scoring.dem_resamples)")
    parser.add_argument("--out", required=True, type=Path, help="validation/intruder_fields.csv")
    args = parser.parse_args(argv)
    missing = [p for p in args.fields_xz if not p.is_file()] + [p for p in args.model_fields if not p.is_dir()]
    if missing:
        parser.error(f"{missing[0]}: not there (--fields-xz takes fields_xz/CASE/RUN.nc files, --model-fields "
                     "model_fields/CASE/MODEL folders)")
    settings = ScoringSettings.from_config(load_config(args.config)) if args.config else ScoringSettings()
    cases = {p.resolve().parent.name for p in args.model_fields}
    case = cases.pop() if len(cases) == 1 else CASE
    scores = score_intruder_fields(args.fields_xz, args.model_fields, settings, case=case)
    table = scores.table(COLUMNS)
    atomic.write_csv(table, args.out)
    show = ["scene", "model", "metric", "value", "u_dem", "dem_noise", "dem_err_rms", "window_points", "replicas",
            "points"]
    with pd.option_context("display.width", 200):
        print(table[show].to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
