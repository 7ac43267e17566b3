"""Synthetic replica fields of planar shear with gravity whose creep follows a known decay-length law.

The known answer the decay-length chain (:mod:`pipeline.scoring.decay_length`) is tested on: the
creep below yield obeys ``xi / d = C (mu_s - mu)^(-beta)``, i.e. with z up and the depth below the
top contact plane ``depth``,

    d ln u / d depth = -k,    k d = (mu_s - mu(depth))^beta / C,

for any beta (both signs and 0), and the fields carry the measurement's noise as the DEM makes it.
What is built, per case of the default config (its geometry: grains, cell, wall load, gravity,
wall speed, replicas, shear before and during the production):

- **Stresses.** sigma_xz is the top wall's shear stress at every depth (no body force along x);
  sigma_zz = P_wall + rho_s nu g depth; mu = |sigma_xz| / p with p = sigma_zz / ``SIGMA_ZZ_OVER_P``
  (the creep's measured 1.11-1.16, docs/validation.md). Each bed's wall stress ratio puts
  mu = mu_s ``YIELD_DEPTH_OVER_D`` below its top (shear_gravity_heavy/r3 of the 2026-12-04
  default: 2.2 d). Each replica's wall stress is offset by ``Noise.tau_rel`` (the replicas'
  scatter of the wall friction), and its creep follows its own smooth mu; the measured mu also
  wanders with the packing's frozen lateral stresses (``Noise.mu_structure_rel``).
- **The band.** Above yield ln u falls linearly from ln V to ln(``U_YIELD_OVER_V`` V) at the
  yield depth; below, the law. C is set per beta so that the calibration case's creep is at
  ``U_REFERENCE_OVER_V`` V ``REFERENCE_DEPTH_OVER_D`` below the top (the default's 2e-4 V at
  12 d): every beta spans the default's decades.
- **The packing.** Each replica's ln u carries a frozen offset in depth, a Gaussian process of
  ``Noise.packing_decades`` (decades, rms) and correlation length ``Noise.packing_length_over_d``:
  the replicas' scatter between packings.
- **Ageing.** u ~ t^``Noise.ageing_exponent`` (t the strain since the shear started) below
  ``Noise.ageing_depths_over_d[1]``, steady above ``[0]``, linear in between (docs/dem.md, "The deep
  creep ages"); the law holds at the production's middle age.
- **Rattling and hops.** Each grain (uniform in height, as many as the case has, unit masses)
  moves with the local creep plus a caged excursion (``Noise.cage_over_d`` d rms, independent
  at every block boundary, so its error on the window's mean falls as 1 / T) and irreversible
  hops (``Noise.hop_over_d`` d rms per square-root strain, independent between blocks: 1 / sqrt(T)).
- **Measurement.** ``u_x_disp`` is the Gaussian-kernel average (width 0.5 d, grid 0.25 d, the
  coarse-graining's defaults) of the grains' displacement over the window divided by its
  duration; its error the larger of the batch-means error over ``Noise.blocks`` sub-windows
  (conservative for caged motion) and the frozen structure's (the kernel average's standard error
  over the grains at their random heights), as the coarse-graining states it. ``mu`` carries a kernel-smoothed noise of
  ``Noise.mu_point_err`` with that stated error.

Units SI; d the mean grain diameter. Nothing here reads DEM output: it stands beside it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from scipy.optimize import brentq

#: sigma_zz / p in the creeping zone (docs/validation.md, "What the DEM is held to": 1.11-1.16).
SIGMA_ZZ_OVER_P = 1.12
#: Solid fraction of the creeping bed (0.60-0.62 there).
SOLID_FRACTION = 0.61
#: mu = mu_s this many d below the top contact plane in the calibration case.
YIELD_DEPTH_OVER_D = 2.5
#: Creep speed at yield, over the wall speed (the creep windows start below 0.1 V).
U_YIELD_OVER_V = 0.12
#: The law's constant C puts the calibration case's creep at U_REFERENCE_OVER_V x V this deep.
REFERENCE_DEPTH_OVER_D = 12.0
U_REFERENCE_OVER_V = 2e-4
#: Coarse-graining: Gaussian kernel width and grid spacing, in d (pipeline.coarse_graining.fields).
KERNEL_WIDTH_OVER_D = 0.5
GRID_SPACING_OVER_D = 0.25


@dataclass(frozen=True)
class Bed:
    """One planar case's geometry and schedule (config ``cases.<name>``), SI units."""

    name: str
    n_grains: int
    cell_x_over_d: float
    cell_y_over_d: float
    wall_pressure: float
    gravity: float
    wall_speed: float
    replicas: int
    shear_before: float       # strain before the production window
    production_strain: float


@dataclass(frozen=True)
class Noise:
    """The measurement's noise (module docstring). Where the defaults come from:

    - ``cage_over_d``: puts the calibration case's deep error (16 strain units, 12-17 d) at
      1-2.5e-4 V, the default's (docs/dem.md: u / err 0.87 at 12 d, u / V 2e-4, after 8 strain;
      halved at 16 by 1 / T);
    - ``hop_over_d``: a diffusive part well under the caged one at depth (the replica means' error
      fell as T^-0.83, mostly 1 / T);
    - ``packing_decades``, ``packing_length_over_d``: a frozen offset between packings of 0.05
      decade over 2 d, beside the grains' own sampling (the stated structure error);
    - ``tau_rel``: the replicas' wall friction scatter (0.005 in mu of about 0.45);
    - ``mu_point_err``: the precision target of mu (0.005), per point;
    - ``mu_structure_rel``, ``mu_structure_length_over_d``: the measured mu's frozen wander about
      the smooth |sigma_xz| / sigma_zz x 1.11 (p, a third of the trace, follows the packing's
      lateral stresses; sigma_zz is smooth to 0.15 %): 6.9 % rms, correlation 0.5 at 1 d (a
      Gaussian kernel of 0.6 d), in the default of 2026-12-04, shear_gravity_heavy/r3 at 3-16 d;
      the creep follows the smooth mu;
    - ``diffusivity_over_rate``: a shear-driven diffusion D / (shear rate d^2), off by default;
      about 3 with ``cage_over_d`` 0.01 and no ``hop_over_d`` matches that run's u_x_disp errors
      at 2-10 d within a factor 2 (its deep floor, 2-3e-5 V at 14-15 d after 7 strain, is 3 times
      lower than this noise's);
    - the ageing: docs/dem.md, "The deep creep ages" (-0.49 to -0.65 below 5 d, -0.07 above);
    - ``blocks``: the coarse-graining's batch-means blocks.
    ``benchmarks/creep_law_sign.py default ROOT`` prints a DEM root's profiles beside these."""

    cage_over_d: float = 0.25
    hop_over_d: float = 0.02
    diffusivity_over_rate: float = 0.0
    packing_decades: float = 0.05
    packing_length_over_d: float = 2.0
    tau_rel: float = 0.01
    mu_point_err: float = 0.004
    mu_structure_rel: float = 0.07
    mu_structure_length_over_d: float = 0.6
    ageing_exponent: float = -0.5
    ageing_depths_over_d: tuple[float, float] = (4.0, 6.0)
    blocks: int = 5


@dataclass(frozen=True)
class Material:
    """Grain diameter (m), density (kg m-3), polydispersity (half-width of the uniform diameters)."""

    d: float = 0.002
    rho_s: float = 2500.0
    polydispersity: float = 0.2


@dataclass(frozen=True)
class Law:
    """``k d = (mu_s - mu)^beta / C`` below yield; ``C`` from :func:`calibrated_law`."""

    beta: float
    mu_s: float
    c: float


@dataclass
class Scene:
    """The beds, the material and the noise one set of synthetic replicas is made of."""

    beds: list[Bed]
    material: Material = field(default_factory=Material)
    noise: Noise = field(default_factory=Noise)


def beds_from_config(config: dict[str, Any], names: tuple[str, ...] = ("shear_gravity", "shear_gravity_fast",
                                                                          "shear_gravity_heavy")) -> Scene:
    """The planar cases ``names`` of a workflow config (a dict as :func:`pipeline.common.config.load_config`
    returns), with its material."""
    dem, cases, mat = config["dem"], config["cases"], config["material"]
    beds = []
    for name in names:
        c = cases[name]
        beds.append(Bed(name=name, n_grains=int(c["n_grains"]), cell_x_over_d=float(c["cell_x"]),
                        cell_y_over_d=float(c["cell_y"]), wall_pressure=float(c["wall_pressure"]),
                        gravity=float(c["gravity"]), wall_speed=float(c["wall_speed"]), replicas=int(c["replicas"]),
                        shear_before=float(c.get("min_shear_strain", dem["min_shear_strain"])),
                        production_strain=float(c.get("production_strain", dem["production_strain"]))))
    return Scene(beds, Material(float(mat["d"]), float(mat["rho_s"]), float(mat.get("polydispersity", 0.0))))


def bed_height(bed: Bed, mat: Material) -> float:
    """Height (m) between the contact planes: the grains' volume over the cell's area and the solid fraction."""
    grain_volume = math.pi / 6.0 * mat.d**3 * (1.0 + mat.polydispersity**2)  # <d^3> of uniform diameters
    return bed.n_grains * grain_volume / (bed.cell_x_over_d * bed.cell_y_over_d * mat.d**2 * SOLID_FRACTION)


def stress_ratio(depth: np.ndarray, bed: Bed, mat: Material, mu_s: float, wall_ratio: float) -> np.ndarray:
    """mu(depth) for a wall shear stress ``wall_ratio`` x P_wall (module docstring)."""
    sigma_zz = bed.wall_pressure + mat.rho_s * SOLID_FRACTION * bed.gravity * depth
    return SIGMA_ZZ_OVER_P * wall_ratio * bed.wall_pressure / sigma_zz


def calibration_wall_ratio(bed: Bed, mat: Material, mu_s: float) -> float:
    """Wall shear stress over P_wall putting yield ``YIELD_DEPTH_OVER_D`` below the top of ``bed``."""
    sigma_zz = bed.wall_pressure + mat.rho_s * SOLID_FRACTION * bed.gravity * YIELD_DEPTH_OVER_D * mat.d
    return mu_s * sigma_zz / (SIGMA_ZZ_OVER_P * bed.wall_pressure)


def log_speed(depth: np.ndarray, mu: np.ndarray, law: Law, d: float) -> np.ndarray:
    """ln(u / V) at ``depth`` (m, increasing) for the stress ratio ``mu`` there: the band's linear
    fall above yield, the law below. The integral of k runs on a grid clustered quadratically at
    the yield depth, midpoint rule, so that k's divergence there for beta < 0 (integrable for
    beta > -1) is integrated to better than 0.1 %."""
    fine = np.linspace(0.0, float(depth.max()), 4001)
    gap_f = law.mu_s - np.interp(fine, depth, mu)
    if not (gap_f > 0).any():
        raise ValueError("the synthetic bed never falls below yield")
    i_y = int(np.argmax(gap_f > 0))
    depth_y = fine[i_y] if i_y == 0 else float(np.interp(0.0, [gap_f[i_y - 1], gap_f[i_y]], [fine[i_y - 1], fine[i_y]]))
    s = np.linspace(0.0, 1.0, 20001)
    grid = depth_y + (fine[-1] - depth_y) * s**2
    mid = 0.5 * (grid[1:] + grid[:-1])
    gap = np.clip(law.mu_s - np.interp(mid, depth, mu), 1e-300, None)
    phase = np.concatenate([[0.0], np.cumsum(gap**law.beta / law.c / d * np.diff(grid))])
    ln_y = math.log(U_YIELD_OVER_V)
    band = ln_y * depth / max(depth_y, 1e-300)
    return np.where(depth < depth_y, band, ln_y - np.interp(depth, grid, phase))


def calibrated_law(beta: float, mu_s: float, scene: Scene) -> Law:
    """The law of exponent ``beta`` whose C puts the first bed's creep at the reference speed and depth."""
    bed, mat = scene.beds[0], scene.material
    ratio = calibration_wall_ratio(bed, mat, mu_s)
    depth = np.linspace(0.0, bed_height(bed, mat), 2001)
    mu = stress_ratio(depth, bed, mat, mu_s, ratio)
    ref = REFERENCE_DEPTH_OVER_D * mat.d

    def miss(log_c: float) -> float:
        return float(np.interp(ref, depth, log_speed(depth, mu, Law(beta, mu_s, math.exp(log_c)), mat.d))
                     - math.log(U_REFERENCE_OVER_V))
    return Law(beta, mu_s, math.exp(brentq(miss, -12.0, 12.0)))


def _smooth_noise(rng: np.random.Generator, z: np.ndarray, length: float, rms: float) -> np.ndarray:
    """A Gaussian process on ``z`` of correlation length ``length`` (Gaussian kernel) and rms ``rms``."""
    if rms == 0:
        return np.zeros(z.size)
    fine = np.arange(z.min() - 4 * length, z.max() + 4 * length, length / 8.0)
    white = rng.standard_normal(fine.size)
    offsets = np.clip((z[:, None] - fine[None, :]) / length, -6.0, 6.0)
    kern = np.exp(-0.5 * offsets**2) * (np.abs(offsets) < 6.0)
    smooth = kern @ white / np.sqrt((kern**2).sum(axis=1))
    return rms * smooth


def replica_fields(bed: Bed, law: Law, scene: Scene, rng: np.random.Generator, run: str) -> xr.Dataset:
    """One replica's fields file as the coarse-graining writes it (the variables and attributes
    :mod:`pipeline.scoring.decay_length` reads), from the law and the noise (module docstring)."""
    mat, noise, d = scene.material, scene.noise, scene.material.d
    height = bed_height(bed, mat)
    z = np.arange(0.0, height + 1e-12 * d, GRID_SPACING_OVER_D * d)
    depth = height - z
    ratio = calibration_wall_ratio(bed, mat, law.mu_s) * (1.0 + noise.tau_rel * rng.standard_normal())
    mu_true = stress_ratio(depth, bed, mat, law.mu_s, ratio)
    order = np.argsort(depth)
    ln_u = np.empty_like(depth)
    ln_u[order] = log_speed(depth[order], mu_true[order], law, d)
    ln_u += math.log(10.0) * _smooth_noise(rng, z, noise.packing_length_over_d * d, noise.packing_decades)
    # Grains: unit masses, uniform in height between the contact planes (half a grain inside them).
    zg = rng.uniform(0.5 * d, height - 0.5 * d, bed.n_grains)
    ln_ug = np.interp(zg, z, ln_u)
    u_g = bed.wall_speed * np.exp(np.clip(ln_ug, -600.0, None))
    depth_g = height - zg
    lo, hi = noise.ageing_depths_over_d
    exponent = noise.ageing_exponent * np.clip((depth_g / d - lo) / (hi - lo), 0.0, 1.0)
    # Block boundaries in strain since the shear began; the law holds at the window's middle age.
    edges = bed.shear_before + bed.production_strain * np.arange(noise.blocks + 1) / noise.blocks
    middle = bed.shear_before + 0.5 * bed.production_strain
    seconds_per_strain = height / bed.wall_speed
    # Creep displacement over each block: integral of u (t / t_mid)^a dt, exactly.
    a1 = exponent[:, None] + 1.0
    drift = u_g[:, None] * middle * seconds_per_strain * ((edges[None, 1:] / middle) ** a1
                                                          - (edges[None, :-1] / middle) ** a1) / a1
    cage = noise.cage_over_d * d * rng.standard_normal((bed.n_grains, noise.blocks + 1))
    block_seconds = bed.production_strain / noise.blocks * seconds_per_strain
    # Irreversible hops: a rate-independent part (hop_over_d d per square-root strain) and a
    # shear-driven diffusion, D = diffusivity_over_rate x shear rate x d^2 (its error ~ sqrt(u)).
    rate_g = np.interp(zg, z, np.abs(np.gradient(bed.wall_speed * np.exp(np.clip(ln_u, -600.0, None)), z)))
    hop_var = ((noise.hop_over_d * d) ** 2 * bed.production_strain / noise.blocks
               + 2.0 * noise.diffusivity_over_rate * rate_g * d**2 * block_seconds)
    hops = np.sqrt(hop_var)[:, None] * rng.standard_normal((bed.n_grains, noise.blocks))
    v_blocks = (drift + np.diff(cage, axis=1) + hops) / block_seconds           # (grains, blocks)
    width = KERNEL_WIDTH_OVER_D * d
    offsets = np.clip((z[:, None] - zg[None, :]) / width, -3.0, 3.0)
    kern = (np.exp(-0.5 * offsets**2) - math.exp(-4.5)) * (np.abs(offsets) < 3.0)
    weight = kern / kern.sum(axis=1, keepdims=True)
    fields_blocks = weight @ v_blocks                                           # (z, blocks)
    u_disp = fields_blocks.mean(axis=1)
    u_err_time = fields_blocks.std(axis=1, ddof=1) / math.sqrt(noise.blocks)
    # The frozen structure: the grains sit at random heights, so the kernel average of a steep
    # profile scatters between packings; its error is the weighted mean's standard error over the
    # grains (the coarse-graining's patch estimate, u_x_disp_err_structure), and the stated error
    # is the larger of the two, as there.
    v_grains = v_blocks.mean(axis=1)
    u_err_structure = np.sqrt((weight**2 * (v_grains[None, :] - u_disp[:, None]) ** 2).sum(axis=1))
    u_err = np.fmax(u_err_time, u_err_structure)
    mu_meas = mu_true + _smooth_noise(rng, z, width, noise.mu_point_err)
    # The packing's frozen lateral stresses: p (a third of the trace) wanders about sigma_zz / 1.12
    # while sigma_xz stays constant, so the measured mu does too; the creep follows the smooth mu.
    mu_meas = mu_meas * (1.0 + _smooth_noise(rng, z, noise.mu_structure_length_over_d * d, noise.mu_structure_rel))
    p = bed.wall_pressure + mat.rho_s * SOLID_FRACTION * bed.gravity * depth
    shear_rate = np.abs(np.gradient(bed.wall_speed * np.exp(np.clip(ln_u, -600.0, None)), z))
    inertial = shear_rate * d / np.sqrt(p / SIGMA_ZZ_OVER_P / mat.rho_s)
    nan = np.full(z.size, np.nan)
    return xr.Dataset(
        {"u_x": ("z", nan), "u_x_err": ("z", np.full(z.size, np.inf)),
         "u_x_disp": ("z", u_disp), "u_x_disp_err": ("z", u_err),
         "u_x_disp_err_time": ("z", u_err_time), "u_x_disp_err_structure": ("z", u_err_structure),
         "mu": ("z", mu_meas), "mu_err": ("z", np.full(z.size, noise.mu_point_err)), "I": ("z", inertial),
         "u_law": ("z", bed.wall_speed * np.exp(np.clip(ln_u, -600.0, None))), "mu_true": ("z", mu_true)},
        coords={"z": z},
        attrs={"d": d, "case": bed.name, "run": run, "wall_speed": bed.wall_speed,
               "z_top_contact_plane": height, "z_bottom_contact_plane": 0.0,
               "z_top_wall": height + 0.42 * d, "z_bottom_wall": -0.42 * d,
               "synthetic_beta": law.beta, "synthetic_c": law.c})


def replica_set(scene: Scene, law: Law, rng: np.random.Generator) -> list[tuple[xr.Dataset, str]]:
    """Every bed's replicas, as (fields, role) pairs: the first bed is the calibration case."""
    return [(replica_fields(bed, law, scene, rng, f"r{r + 1}"), "calibration" if i == 0 else "held_out")
            for i, bed in enumerate(scene.beds) for r in range(bed.replicas)]
