"""Mesh dependence of the planar solvers: shear-band width and velocity profile against grid spacing.

Pure numerics: a geometry, parameter dataclasses and a list of ``n_grid`` in, a table out.

Definitions (SI units; z up from the fixed bottom wall, u_x >= 0 along the top wall's motion):

* **Band width** ``w`` (m): the thickness over which u_x rises from 10 % to 90 % of the wall
  speed V, ``w = z_90 - z_10``, each crossing located by linear interpolation between the two
  nodes that bracket it (the first node at or above the level, going up from the bottom wall).
  Chosen over the 1/e width of the shear-rate peak because it needs only u_x, which every model
  returns (the local critical-state model has no shear-rate profile: a Dirac mass), and because
  it is finite for a velocity jump: a jump across one node gives ``w = 1.6 dx`` inside the layer
  and ``0.8 dx`` on a wall, so a zero-thickness band shows as ``w`` proportional to dx.
  For homogeneous shear ``w = 0.8 H``.
* **dx** (m): the largest node spacing of the solution grid (uniform grids: H / (n_grid - 1);
  the local mu(I) grid is uniform in pressure in the flowing layer plus a static part, and the
  volume-averaged nodes move as the layer dilates, so the largest spacing is the honest measure).
* **u_x_rmse_vs_finest** (-): RMS over the layer of (u_x - u_x on the finest grid) / V, both
  interpolated linearly onto one uniform evaluation grid (``EVAL_POINTS`` nodes spanning the
  deepest final layer; beyond a layer's top u_x = V).
* **converged** (0/1, per case and model): the two finest grids that solved agree to
  ``CONVERGED_RTOL`` (1 %) in band width (relative) and in u_x (RMS relative to V).

A solve that raises a ``ContinuumError`` is kept as a row with its message in ``error`` and NaN
measures: where a solver fails is itself a result (see pipeline/stability/failure_catalogue.py).
"""
from __future__ import annotations

import time
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd
import xarray as xr

import continuum
from continuum.errors import ContinuumError
from continuum.geometry import PlanarShear
from continuum.packing import InitialPacking

#: Default sweep: grid doublings from 16 to 4096 nodes.
N_GRIDS: tuple[int, ...] = tuple(2**k for k in range(4, 13))
#: Relative change between the two finest grids under which a model counts as converged.
CONVERGED_RTOL = 0.01
#: Nodes of the common uniform grid on which profiles are compared.
EVAL_POINTS = 16385
#: Models whose solver accepts an initial packing (the rate-independent ones).
PACKING_MODELS = ("critical_state", "volume_averaged")
COLUMNS = ["case", "model", "n_grid", "dx", "band_width", "u_x_rmse_vs_finest", "converged",
           "solve_seconds", "error"]


def _crossing(z: np.ndarray, u: np.ndarray, level: float) -> float:
    """Height (m) where u first reaches ``level`` going up, linearly interpolated; NaN if never."""
    above = np.flatnonzero(u >= level)
    if above.size == 0:
        return float("nan")
    k = int(above[0])
    if k == 0:
        return float(z[0])
    u0, u1 = float(u[k - 1]), float(u[k])
    return float(z[k - 1] + (level - u0) / (u1 - u0) * (z[k] - z[k - 1]))


def band_width(z: np.ndarray, u_x: np.ndarray, wall_speed: float, low: float = 0.1,
               high: float = 0.9) -> float:
    """Thickness (m) over which u_x goes from ``low`` V to ``high`` V (see module docstring).

    Args:
        z: node heights above the bottom wall (m), increasing.
        u_x: velocity at the nodes (m s-1), 0 at the bottom wall and V at the top wall.
        wall_speed: V (m s-1), > 0.
    """
    if not wall_speed > 0.0:
        raise ValueError(f"band width needs a moving wall, got V = {wall_speed!r}")
    z = np.asarray(z, dtype=float)
    u = np.asarray(u_x, dtype=float)
    return _crossing(z, u, high * wall_speed) - _crossing(z, u, low * wall_speed)


def grid_spacing(z: np.ndarray) -> float:
    """Largest node spacing (m) of a solution grid."""
    return float(np.max(np.diff(np.asarray(z, dtype=float))))


def _solve(model: str, geometry: PlanarShear, params: Any, n_grid: int, case: str,
           nu_initial: InitialPacking) -> xr.Dataset:
    options: dict[str, Any] = {"case": case}
    if model in PACKING_MODELS and nu_initial is not None:
        options["nu_initial"] = nu_initial
    return continuum.solve(model, geometry, params, n_grid=n_grid, **options)


def study_model(model: str, geometry: PlanarShear, params: Any, n_grids: Sequence[int] = N_GRIDS,
                case: str = "", nu_initial: InitialPacking = None) -> pd.DataFrame:
    """Solve one model on every grid of ``n_grids``; one row per grid (columns ``COLUMNS``).

    Args:
        model: continuum model name.
        geometry: the planar cell.
        params: the model's parameter dataclass.
        n_grids: grid sizes (``n_grid`` of the solver), any order; sorted coarse to fine.
        case: label of the case (goes into the table and the solvers' error messages).
        nu_initial: initial packing for the rate-independent models (ignored by the others,
            whose steady state does not depend on it).
    """
    V = geometry.wall_speed
    rows: list[dict[str, Any]] = []
    profiles: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for n in sorted(set(int(k) for k in n_grids)):
        row: dict[str, Any] = {"case": case, "model": model, "n_grid": n, "dx": np.nan,
                               "band_width": np.nan, "solve_seconds": np.nan, "error": ""}
        t0 = time.perf_counter()
        try:
            solution = _solve(model, geometry, params, n, case, nu_initial)
        except ContinuumError as exc:
            row["solve_seconds"] = time.perf_counter() - t0
            row["error"] = f"{type(exc).__name__}: {exc}"
            rows.append(row)
            continue
        row["solve_seconds"] = time.perf_counter() - t0
        z = solution.z.values
        row["dx"] = grid_spacing(z)
        if "u_x" in solution:
            u = solution.u_x.values
            row["band_width"] = band_width(z, u, V)
            profiles[n] = (z, u)
        else:
            # e.g. critical state at uniform pressure and packing: the model leaves u undetermined
            row["error"] = "velocity not determined by the model (u_x not returned)"
        rows.append(row)
    table = pd.DataFrame(rows)
    table["u_x_rmse_vs_finest"] = np.nan
    table["converged"] = 0
    if profiles:
        solved = sorted(profiles)
        top = max(float(z[-1]) for z, _ in profiles.values())
        z_eval = np.linspace(0.0, top, EVAL_POINTS)
        # np.interp holds u at its end values beyond a grid's top: V, the wall speed there
        on_eval = {n: np.interp(z_eval, *profiles[n]) for n in solved}
        finest = on_eval[solved[-1]]
        for n in solved:
            rms = float(np.sqrt(np.mean((on_eval[n] - finest) ** 2))) / V
            table.loc[table.n_grid == n, "u_x_rmse_vs_finest"] = rms
        if len(solved) >= 2:
            w = table.set_index("n_grid")["band_width"]
            w_fine, w_next = float(w[solved[-1]]), float(w[solved[-2]])
            rms_next = float(table.loc[table.n_grid == solved[-2], "u_x_rmse_vs_finest"].iloc[0])
            ok = abs(w_next - w_fine) <= CONVERGED_RTOL * abs(w_fine) and rms_next <= CONVERGED_RTOL
            table["converged"] = int(ok)
    return table[COLUMNS]


def mesh_study(geometry: PlanarShear, params: Mapping[str, Any], n_grids: Sequence[int] = N_GRIDS,
               case: str = "", nu_initial: InitialPacking = None) -> pd.DataFrame:
    """:func:`study_model` for every model in ``params`` (model name -> parameter dataclass)."""
    frames = [study_model(model, geometry, p, n_grids, case, nu_initial) for model, p in params.items()]
    return pd.concat(frames, ignore_index=True)


def weak_plane_packing(geometry: PlanarShear, line: continuum.CriticalStateLine, excess: float = 0.005,
                       dip: float = 0.5, height: float | None = None,
                       width: float | None = None) -> InitialPacking:
    """Initial packing of the localisation case: denser than critical by ``excess`` everywhere
    except a smooth (Gaussian) dip of relative depth ``dip`` at ``height`` (default 0.4142 H, an
    irrational fraction so that no two nodes of a uniform grid are equidistant from it), of 1/e
    half-width ``width`` (default 2 d).

    Why: dense planes are stronger than critical ones (Y(alpha)/alpha falls with alpha), so the
    least dense plane yields first, dilates to its critical packing and stays the weakest: with
    g = 0 nothing else selects a plane. The perturbation is smooth and resolved (width >> dx on
    fine grids), so a well-posed model must converge to a grid-independent profile, while a
    model that localises on a plane of zero thickness gives a band set by dx.

    The critical packing uses the top-wall pressure (exact at g = 0).
    """
    z_w = 0.4142 * geometry.depth if height is None else height
    w = 2.0 * geometry.d if width is None else width
    nu_c = float(line.nu_cs(geometry.top_pressure))

    def nu(z: np.ndarray) -> np.ndarray:
        return nu_c + excess * (1.0 - dip * np.exp(-(((np.asarray(z) - z_w) / w) ** 2)))

    return nu
