"""The report's intruder field comparison (issue 55, item 4): DEM and every model side by side around
the rod for one scene, on one colour scale per row (the velocity along x relative to the rod over
V, and the stress ratio |sigma_xz| / p), and the table of the field scores
(``validation/intruder_fields.csv``, ``pipeline.scoring.intruder_field_scores``).

Inputs under the output root: ``fields_xz/{case}/{run}.nc`` (the DEM, replicas averaged),
``model_fields/{case}/{model}/{scene}.nc`` (``pipeline.models.intruder_fields``) and the scores'
table. Whatever is missing is said in the section, not drawn."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import matplotlib.colors as mcolors
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import xarray as xr
from matplotlib.patches import Circle

from pipeline.common.layout import intruder_cases, model_names
from pipeline.report.html import table_html
from pipeline.scoring.intruder_field_scores import METRICS, WINDOW_OVER_ROD, rod_of, scene_of_run

#: The scores' table under the output root.
TABLE = Path("validation") / "intruder_fields.csv"
#: Where |u_x_rel| / V turns from linear to logarithmic colours: the creep around the rod is
#: 1e-4 to 1e-2 of V, the band above it ~1.
LINEAR_BELOW = 1e-3


def model_scene_files(root: Path, config: dict[str, Any], case: str) -> dict[str, dict[str, Path]]:
    """model -> scene -> its fields file, for the config's models that have any."""
    out = {}
    for model in model_names(config):
        folder = root / "model_fields" / case / model
        files = {p.stem: p for p in sorted(folder.glob("*.nc"))} if folder.is_dir() else {}
        if files:
            out[model] = files
    return out


def pick_scene(models: dict[str, dict[str, Path]], dem_scenes: set[str]) -> str | None:
    """The scene drawn: one with DEM fields that the most models cover, the depth sweep's (no
    force-sweep suffix ``-F``) first, then the deepest rod (the creeping scene the issue is about)."""
    counts = {s: sum(s in files for files in models.values()) for s in dem_scenes}
    counts = {s: n for s, n in counts.items() if n > 0}
    if not counts:
        return None

    def depth(scene: str) -> float:
        path = next(files[scene] for files in models.values() if scene in files)
        with xr.open_dataset(path) as ds:
            return float(ds.attrs.get("rod_depth_over_d", 0.0))

    return sorted(counts, key=lambda s: (-counts[s], "-F" in s, -depth(s), s))[0]


def dem_mean(files: list[Path]) -> xr.Dataset:
    """The replicas' mean of u_x_rel and mu on the first replica's grid (the replicas share the
    cell; a replica on another grid is interpolated onto it)."""
    datasets = [xr.load_dataset(f) for f in sorted(files)]
    ref = datasets[0]
    fields = []
    for ds in datasets:
        part = ds[["u_x_rel", "mu", "rho_body"]] if "rho_body" in ds else ds[["u_x_rel", "mu"]]
        if ds is not ref:
            part = part.interp(x=ref.x, z=ref.z)
        fields.append(part)
    out = xr.concat(fields, dim="replica").mean("replica")
    out.attrs = dict(ref.attrs)
    out.attrs["replicas"] = len(datasets)
    return out


def field_figure(scene: str, dem: xr.Dataset, models: dict[str, Path], figures: Any) -> str:
    """Two rows (u_x_rel / V, mu) of DEM and model panels on shared colour scales (module docstring)."""
    xc, zc, diameter = rod_of(dem)
    d, V = float(dem.attrs["d"]), float(dem.attrs["wall_speed"])
    lx = float(np.atleast_1d(dem.attrs["cell"])[0])
    z_wall, z_top = float(dem.attrs["z_bottom_wall"]), float(dem.attrs["z_top_wall"])
    half_x = min(WINDOW_OVER_ROD * diameter, 0.5 * lx)
    half_z = WINDOW_OVER_ROD * diameter
    panels = []  # (title, x / d, z / d, u_rel / V, mu) on (x, z)
    x = (dem.x.values - xc + 0.5 * lx) % lx - 0.5 * lx
    order = np.argsort(x)
    xx, zz = np.meshgrid(x, dem.z.values, indexing="ij")
    inside = np.hypot(xx, zz - zc) < 0.5 * diameter
    if "rho_body" in dem:
        inside |= dem.rho_body.values < 0.2 * float(np.nanmax(dem.rho_body.values))
    panels.append((f"DEM ({dem.attrs['replicas']} replica{'s' if dem.attrs['replicas'] > 1 else ''})",
                   x[order] / d, (dem.z.values - z_wall) / d,
                   np.where(inside, np.nan, dem.u_x_rel.values / V)[order],
                   np.where(inside, np.nan, dem.mu.values)[order]))
    for model, path in models.items():
        with xr.open_dataset(path) as ds:
            solid = ds.solid.values.astype(bool)
            panels.append((model, ds.x.values / d, (ds.z.values - z_wall) / d,
                           np.where(solid, np.nan, ds.u_x_rel.values / V), np.where(solid, np.nan, ds.mu_xz.values)))

    def in_window(px: np.ndarray, pz: np.ndarray) -> np.ndarray:
        gx, gz = np.meshgrid(px * d, pz * d + z_wall, indexing="ij")
        return (np.abs(gx) <= half_x) & (np.abs(gz - zc) <= half_z)

    u_max = max(float(np.nanmax(np.abs(p[3][in_window(p[1], p[2])]), initial=0.0)) for p in panels)
    mu_all = np.concatenate([p[4][in_window(p[1], p[2])].ravel() for p in panels])
    mu_all = mu_all[np.isfinite(mu_all)]
    mu_max = float(np.percentile(mu_all, 98)) if mu_all.size else 1.0
    u_norm = mcolors.SymLogNorm(linthresh=LINEAR_BELOW, vmin=-max(u_max, 2 * LINEAR_BELOW),
                                vmax=max(u_max, 2 * LINEAR_BELOW), base=10)
    mu_norm = mcolors.Normalize(vmin=0.0, vmax=mu_max)
    fig, axes = plt.subplots(2, len(panels), figsize=(2.9 * len(panels) + 1.2, 6.4), squeeze=False,
                             sharex=True, sharey=True)
    meshes: list[list[Any]] = [[], []]
    for k, (title, px, pz, u, mu) in enumerate(panels):
        for row, (values, norm, cmap) in enumerate(((u, u_norm, "RdBu_r"), (mu, mu_norm, "viridis"))):
            ax = axes[row][k]
            mesh = ax.pcolormesh(px, pz, values.T, norm=norm, cmap=cmap, shading="nearest", rasterized=True)
            ax.add_patch(Circle((0.0, (zc - z_wall) / d), 0.5 * diameter / d, fill=False, color="k", lw=1))
            ax.set_xlim(-half_x / d, half_x / d)
            ax.set_ylim(max(zc - half_z, z_wall) / d - z_wall / d, (min(zc + half_z, z_top) - z_wall) / d)
            ax.set_aspect("equal")
            meshes[row].append(mesh)
            if row == 0:
                ax.set_title(title, fontsize=9)
            else:
                ax.set_xlabel("x from the rod's axis / d")
        if k == 0:
            axes[0][0].set_ylabel("height above the bottom wall / d")
            axes[1][0].set_ylabel("height above the bottom wall / d")
    fig.colorbar(meshes[0][0], ax=list(axes[0]), label="(u_x - U_rod) / V, symlog", shrink=0.9)
    fig.colorbar(meshes[1][0], ax=list(axes[1]), label="|sigma_xz| / p", shrink=0.9)
    return figures.add("intruder_fields_models", fig,
                       f"Scene {scene}: the flow around the rod in its frame, DEM (replicas' mean, fields_xz/) and each "
                       "model's own 2D solution (model_fields/), on one colour scale per row: top, the velocity along x "
                       f"relative to the rod over the wall speed (symmetric log, linear within {LINEAR_BELOW:g}); "
                       "bottom, the stress ratio |sigma_xz| / p (the DEM's definition for every panel; colour scale to "
                       "its 98th percentile). Window: the rod's axis +- 3 rod diameters (within the cell and the "
                       "walls' grains); circle: the rod; blank: the rod (DEM: where its grains are missing).")


def score_table(root: Path) -> str:
    """The field scores per model, metric and scene, value (u_dem), and the replicas' noise."""
    path = root / TABLE
    if not path.exists():
        return ""
    table = pd.read_csv(path)
    if table.empty:
        return ""
    table["cell"] = [f"{v:.3g} ({u:.2g})" if math.isfinite(u) else f"{v:.3g}" for v, u in zip(table.value, table.u_dem)]
    scenes = [s for s in sorted(set(table.scene)) if s != "all"] + (["all"] if "all" in set(table.scene) else [])
    wide = table.pivot_table(index=["metric", "model"], columns="scene", values="cell", aggfunc="first")
    wide = wide.reindex(columns=scenes).rename(columns={"all": "all scenes (RMS)"}).reset_index()
    order = {m: k for k, m in enumerate(METRICS)}
    wide = wide.sort_values(["metric", "model"], key=lambda c: c.map(order) if c.name == "metric" else c)
    noise = table[(table.scene != "all")].groupby(["metric", "scene"])["dem_noise"].first().unstack()
    rows = []
    for metric in [m for m in METRICS if m in set(table.metric)]:
        if metric in noise.index and noise.loc[metric].notna().any():
            rows.append({"metric": metric, "model": "DEM: replica against replica",
                         **{s: f"{noise.loc[metric, s]:.3g}" for s in noise.columns if math.isfinite(noise.loc[metric, s])}})
    if rows:
        wide = pd.concat([wide, pd.DataFrame(rows)], ignore_index=True).fillna("")
    return table_html(wide.fillna(""))


def intruder_fields_section(root: Path, config: dict[str, Any], figures: Any, scene: str | None = None) -> str:
    """The section (module docstring); empty without any model's fields. ``scene``: the one drawn
    (default ``pick_scene``'s)."""
    parts = []
    for case in intruder_cases(config):
        models = model_scene_files(root, config, case)
        if not models:
            continue
        dem_files: dict[str, list[Path]] = {}
        for f in sorted((root / "fields_xz" / case).glob("*.nc")):
            dem_files.setdefault(scene_of_run(f.stem), []).append(f)
        parts.append("<h3>The fields around the rod: DEM and models</h3>"
                     "<p class='note'>Each model's own 2D solution (its nominal solve at its scene, written per scene "
                     "as CF NetCDF and VTK under model_fields/) against the DEM's x-z fields in the rod's frame. "
                     "Scores (validation/intruder_fields.csv): the RMS over the DEM's grid points within 3 rod "
                     "diameters of the rod's axis, a kernel width off its surface and the walls, of the velocity "
                     "relative to the rod over V (intruder_field_velocity_rmse), of |sigma_xz| / p "
                     "(intruder_field_mu_rmse) and of the solid fraction where the model has one "
                     "(intruder_field_nu_rmse; mu(I): nu(I), Cosserat: nu_cs(p), critical state and the "
                     "volume-averaged model: their 1D packing carried unchanged). The DEM reference is the replicas' "
                     "mean; in brackets u_dem, its uncertainty (the replicas' scatter; one replica: its stated "
                     "errors); 'all scenes' is the RMS over the scenes a model covers. The draws' and the grid "
                     "study's fields are not stored, so u_input and u_num are not part of these scores.</p>")
        if scene not in dem_files:
            scene = pick_scene(models, set(dem_files))
        if scene is None:
            parts.append("<p class='note'>No scene has both DEM fields (fields_xz/) and a model's fields.</p>")
        else:
            dem = dem_mean(dem_files[scene])
            parts.append(field_figure(scene, dem, {m: f[scene] for m, f in models.items() if scene in f}, figures))
        table = score_table(root)
        parts.append(table or "<p class='note'>The field scores (validation/intruder_fields.csv) are not there yet.</p>")
    return "\n".join(parts)
