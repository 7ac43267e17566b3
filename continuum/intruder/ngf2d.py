"""NGF in 2D (x-z) on the periodic shear cell, with or without the rigid rod (Henann & Kamrin 2014).

Equations (see docs/intruder.md):
    div(2 eta D) - grad p - rho_s nu g e_z = 0,   div u = 0,   eta = p / g_f,
    A^2 d^2 lap g_f = |mu - mu_s| (g_f - g_loc(mu, p)),   mu = tau / p,  tau = |T'| / sqrt(2),
i.e. gammadot = g_f mu with the stress parallel to the deformation rate (Henann & Kamrin 2013).
Walls: no slip; dg_f/dn = 0. Rod: no slip (rigid translation (U, 0)); dg_f/dn = 0 on its surface.

Iteration (Picard): for the current fluidity and pressure, the Stokes problem is linear, so it is
solved for three right-hand sides sharing one factorisation (gravity with everything at rest;
the top wall at unit speed; the rod at unit speed) and superposed; the rod speed U follows from
the rod's force balance, F + F_fluid(U_top, U) = 0. The top wall is driven by its mean shear
stress tau_top, updated each iteration with the 1D sensitivity d ln V / d ln tau so that its speed
converges to V: with the wall speed imposed directly, the Picard map amplifies the global mode
(a too-small fluidity gives a too-large stress, hence a much larger local fluidity) and diverges.
Then mu and p from the new stress give the fluidity by one linear solve.
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import scipy.sparse as sp
import xarray as xr
from scipy import ndimage
from scipy.sparse.linalg import spsolve

from .. import ngf
from ..errors import ConvergenceError, OutOfRangeError
from ..geometry import PlanarShear
from ..parameters import NGFParameters
from .mac import MacGrid, RodMask, assemble, build_operators, rod_mask
from .scene import GridOptions, RodIntruder

MODEL = "ngf"
_P_FLOOR = 0.05  # floor on p, as a fraction of P_wall, used in early iterates only
#: Floor on the frozen fluidity, relative to its largest value. NGF's fluidity decays as
#: exp(-z / xi) below the shear zone; with a small A it underflows (1e-255 of its peak at A = 0.01)
#: and the Stokes system with eta = p / g is singular to working precision. Material 1e9 times
#: less fluid than the shear band is at rest for any comparison with the DEM (U is then bounded
#: by this floor); where the floor reaches the rod it is reported (``floor_at_rod``).
FLUIDITY_FLOOR = 1e-9
#: Largest momentum residual (in units of P_wall / d) of an accepted 2D solve.
RESIDUAL_TOL = 1e-6


def fluidity_laplacian(grid: MacGrid, solid: np.ndarray) -> sp.csr_matrix:
    """Five-point Laplacian (m-2) over the material cells, periodic in x, with zero flux through
    the walls and the rod surface (links to walls and solid cells are left out)."""
    nx, nz = grid.nx, grid.nz
    i, j = np.meshgrid(np.arange(nx), np.arange(nz))
    c = (j * nx + i).ravel()
    rows, cols, vals = [], [], []
    links = [((j * nx + (i + 1) % nx).ravel(), np.ones(c.size, bool), 1.0 / grid.hx**2),
             ((np.minimum(j + 1, nz - 1) * nx + i).ravel(), (j < nz - 1).ravel(), 1.0 / grid.hz**2)]
    for nb, ok, w in links:
        ok = ok & ~solid[c] & ~solid[nb]
        a, b = c[ok], nb[ok]
        rows += [a, b, a, b]
        cols += [b, a, a, b]
        vals += [np.full(a.size, w), np.full(a.size, w), np.full(a.size, -w), np.full(a.size, -w)]
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(grid.n_cells, grid.n_cells))


def _fill_solid(values: np.ndarray, solid: np.ndarray, grid: MacGrid) -> np.ndarray:
    """Copy into solid cells the value of the nearest material cell (the rod is rigid, so its
    viscosity only enters the corner averages next to its surface)."""
    if not solid.any():
        return values
    mask2 = solid.reshape(grid.nz, grid.nx)
    _, (jj, ii) = ndimage.distance_transform_edt(mask2, sampling=(grid.hz, grid.hx), return_indices=True)
    return values.reshape(grid.nz, grid.nx)[jj, ii].ravel()


# The far-field fluidity underflows to zero deep in the bed when A is small (see FLUIDITY_FLOOR).
@np.errstate(under="ignore")
def solve_2d(geometry: PlanarShear, params: NGFParameters, cell_length_x: float,
             rod: RodIntruder | None, options: GridOptions = GridOptions(),
             case: str | None = None, coupling: str = "frozen") -> dict:
    """Steady NGF flow in the periodic cell, with the rod (held at its height, translating under
    its force) or without it (then the solution must be the 1D planar one).

    coupling:
        ``"frozen"`` (default): the fluidity and the pressure in eta = p / g are the far field's
        (the 1D planar solution), so the problem is one linear Stokes solve and U = U_drift +
        F / K exactly: the secondary-rheology limit of small F (Henann & Kamrin 2014), in which
        the fluidity next to the rod is sustained non-locally by the shear zone.
        ``"coupled"``: the fluidity equation is solved in 2D with the stress of the flow around
        the rod (Picard iteration, see the module docstring); this is the full NGF prediction,
        including the faster-than-linear rise of U with F. It needs strong damping next to the
        staircase rod (stress concentrations at its corners), converges in ~100 iterations at
        4 cells per d and is not guaranteed on coarser grids.

    Returns a dict: ``speed`` (rod speed, m s-1; None without rod), ``fields`` (xr.Dataset on the
    cell centres), ``converged``, ``iterations``, ``residual``, ``n_grid``, ``tau_top`` (Pa),
    ``drift_speed``, ``mobility``, ``vertical_force`` (N m-1, fluid on rod, +z),
    ``torque`` (N, fluid on rod, about +y), ``planar_solve_seconds``, ``solve_seconds``.

    Raises:
        ConvergenceError: the Picard iteration did not reach ``options.tolerance``.
        OutOfRangeError: a negative pressure appeared (force far beyond what the bed can carry).
    """
    t0 = time.perf_counter()
    if rod is not None:
        rod.check_inside(geometry, cell_length_x)
    V, P, H, d = geometry.wall_speed, geometry.wall_pressure, geometry.depth, geometry.d
    if V <= 0.0:
        raise OutOfRangeError(MODEL, "the 2D solve needs a moving top wall (V > 0)", case)
    nx, nz = options.counts(geometry, cell_length_x)
    grid = MacGrid(nx, nz, cell_length_x / nx, H / nz)
    ops = build_operators(grid)
    mask: RodMask = rod_mask(grid, rod, 0.5 * cell_length_x)
    material = ~mask.solid_cells
    xc, zc = grid.cell_xz()

    # far field and starting point: the 1D planar solution on a finer grid
    t1 = time.perf_counter()
    n1d = 8 * nz + 1
    planar = ngf.solve(geometry, params, n_grid=n1d, case=case)
    planar_seconds = time.perf_counter() - t1
    faster = ngf.solve(replace(geometry, wall_speed=1.02 * V), params, n_grid=n1d, case=case)
    tau = float(planar.attrs["tau"])
    slope = np.log(1.02) / np.log(faster.attrs["tau"] / tau)  # d ln V / d ln tau_top

    g = np.interp(zc, planar.z.values, planar.fluidity.values)
    weight = geometry.rho_s * params.nu * geometry.gravity
    p = P + weight * (H - zc)
    body = np.full(grid.n_w, weight)
    lap = (params.A * d) ** 2 * fluidity_laplacian(grid, mask.solid_cells)
    ident_solid = sp.diags(mask.solid_cells.astype(float))
    nc, nw = grid.n_cells, grid.n_w
    top_corners = slice(nz * nx, (nz + 1) * nx)
    vol = grid.hx * grid.hz
    force = 0.0 if rod is None else rod.force_per_length

    if coupling == "frozen":
        return _frozen(geometry, params, cell_length_x, rod, grid, ops, mask, planar, planar_seconds,
                       g, p, body, t0)
    if coupling != "coupled":
        raise ValueError(f"coupling must be 'frozen' or 'coupled', got {coupling!r}")
    relax = options.relaxation
    change = np.inf
    last_change = np.inf
    it = 0
    for it in range(1, options.max_iterations + 1):
        eta = p / g
        system = assemble(grid, ops, mask, eta)
        x_b = system.solve(0.0, 0.0, body)
        x_t = system.solve(1.0, 0.0, None)
        a_b = system.shear_stress_corners(x_b, 0.0)[top_corners].mean()
        a_t = system.shear_stress_corners(x_t, 1.0)[top_corners].mean()
        if rod is not None:
            x_r = system.solve(0.0, 1.0, None)
            a_r = system.shear_stress_corners(x_r, 0.0)[top_corners].mean()
            f_b = vol * system.residual(x_b, 0.0, None)[:nc][mask.u_faces].sum()
            f_t = vol * system.residual(x_t, 1.0, None)[:nc][mask.u_faces].sum()
            f_r = vol * system.residual(x_r, 0.0, None)[:nc][mask.u_faces].sum()
            u_top, u_rod = np.linalg.solve([[a_t, a_r], [f_t, f_r]], [tau - a_b, -force - f_b])
            x = x_b + u_top * x_t + u_rod * x_r
        else:
            u_top, u_rod = (tau - a_b) / a_t, 0.0
            x = x_b + u_top * x_t
        u, w, pp = system.split(x)
        pp = pp.copy()
        top_row = pp[(nz - 1) * nx:] * 1.5 - pp[(nz - 2) * nx:(nz - 1) * nx] * 0.5
        pp += P - top_row.mean()  # the top wall carries P_wall on average (sigma_zz = p there)
        p_min = float(pp[material].min())
        # a granular bed carries no tension: where the Stokes pressure drops below a small floor
        # (possible in early iterates next to the rod) the floor is used in eta and mu; a
        # converged solution that still needs it is rejected below
        pp = np.maximum(pp, _P_FLOOR * P)
        s_xz = ops.centre_from_corners @ system.shear_stress_corners(x, u_top)
        s_xx = system.normal_deviator_centres(x)
        mu = np.sqrt(s_xx**2 + s_xz**2)[material] / pp[material]
        dmu = np.zeros(nc)
        dmu[material] = np.maximum(np.abs(mu - params.mu_i.mu_s), params.delta_mu)
        rhs = np.zeros(nc)
        rhs[material] = -dmu[material] * ngf.local_fluidity(mu, pp[material], params, d, geometry.rho_s)
        g_new = spsolve((lap - sp.diags(dmu) + ident_solid).tocsc(), rhs)
        if not np.all(g_new[material] > 0.0):
            raise ConvergenceError(MODEL, np.nan, "non-positive fluidity: grid too coarse for xi", case)
        g_new = _fill_solid(g_new, mask.solid_cells, grid)
        change = float(np.max(np.abs(np.log(g_new[material]) - np.log(g[material]))))
        speed_error = abs(u_top / V - 1.0)
        if change > 2.0 * max(last_change, 1e-4) and relax > 0.125:
            relax *= 0.5  # safeguard: damp the update when the iteration stops contracting
        last_change = change
        g_next = np.exp((1.0 - relax) * np.log(g) + relax * np.log(g_new))
        if u_top <= 0.0:
            raise ConvergenceError(MODEL, speed_error, "top wall moving backwards", case)
        # Top-wall speed the new fluidity would give at this tau, predicted from the shear flux
        # int <T_xz g / p> dz (exact for planar flow); updating tau from the old fluidity's speed
        # instead makes the (tau, g) iteration a slowly spiralling map (|eigenvalue| ~ 0.95).
        u_top_pred = u_top * _shear_flux(s_xz, g_next, pp, material) / _shear_flux(s_xz, g, pp, material)
        g = g_next
        p = _fill_solid(pp, mask.solid_cells, grid)
        tau *= (V / u_top_pred) ** (1.0 / slope)
        if change < options.tolerance and speed_error < options.tolerance:
            break
    residual = max(change, speed_error)
    if residual >= options.tolerance:
        raise ConvergenceError(MODEL, residual, f"Picard iteration not converged in {it} iterations", case)
    if p_min < _P_FLOOR * P:
        raise OutOfRangeError(MODEL, f"pressure {p_min:.3g} Pa next to the rod: the bed would open in tension", case)

    out: dict = {"converged": True, "iterations": it, "residual": residual, "n_grid": nc,
                 "tau_top": float(tau), "planar_solve_seconds": planar_seconds, "planar": planar,
                 "coupling": coupling}
    _rod_outputs(out, system, x, u_top, rod, grid, mask, cell_length_x, V,
                 (f_b, f_t, f_r) if rod is not None else None, u_rod)
    out["fields"] = _fields(grid, mask, u, w, pp, g, mu, V if rod is None else u_rod)
    out["solve_seconds"] = time.perf_counter() - t0
    return out


def _rod_outputs(out: dict, system, x: np.ndarray, u_top: float, rod: RodIntruder | None, grid: MacGrid,
                 mask: RodMask, cell_length_x: float, V: float, forces: tuple | None, u_rod: float) -> None:
    """Speed, drift, mobility, vertical force and torque of the rod (fluid on rod, per length)."""
    if rod is None:
        out["speed"] = None
        return
    nc, nw, nx, nz = grid.n_cells, grid.n_w, grid.nx, grid.nz
    f_b, f_t, f_r = forces
    vol = grid.hx * grid.hz
    r_all = system.residual(x, u_top, None)
    r_u, r_w = r_all[:nc][mask.u_faces], r_all[nc:nc + nw][mask.w_faces]
    zu = np.repeat(grid.z_centres, nx)[mask.u_faces]
    xw = np.tile(grid.x_centres, nz - 1)[mask.w_faces]
    out.update({
        "speed": float(u_rod),
        "mobility": float(-1.0 / f_r),
        "drift_speed": float(-(f_b + f_t * V) / f_r),
        "vertical_force": float(vol * r_w.sum()),
        "torque": float(vol * (np.sum((zu - rod.depth_from_bottom) * r_u)
                               - np.sum((xw - 0.5 * cell_length_x) * r_w))),
    })


def _frozen(geometry: PlanarShear, params: NGFParameters, cell_length_x: float, rod: RodIntruder | None,
            grid: MacGrid, ops, mask: RodMask, planar: xr.Dataset, planar_seconds: float,
            g: np.ndarray, p: np.ndarray, body: np.ndarray, t0: float) -> dict:
    """One Stokes solve with eta = p_1D / g_1D; the top wall moves at V."""
    V, P = geometry.wall_speed, geometry.wall_pressure
    nc, nx, nz = grid.n_cells, grid.nx, grid.nz
    vol = grid.hx * grid.hz
    floor = FLUIDITY_FLOOR * float(g.max())
    floor_at_rod = False
    if rod is not None:
        xc, zc = grid.cell_xz()
        near = np.hypot(xc - 0.5 * cell_length_x, zc - rod.depth_from_bottom) <= rod.diameter
        floor_at_rod = bool(np.any(g[near & ~mask.solid_cells] < floor))
    g = np.maximum(g, floor)
    system = assemble(grid, ops, mask, p / g)
    x_b = system.solve(0.0, 0.0, body)
    x_t = system.solve(1.0, 0.0, None)
    x = x_b + V * x_t
    forces, u_rod = None, float("nan")
    if rod is not None:
        x_r = system.solve(0.0, 1.0, None)
        f_b = vol * system.residual(x_b, 0.0, None)[:nc][mask.u_faces].sum()
        f_t = vol * system.residual(x_t, 1.0, None)[:nc][mask.u_faces].sum()
        f_r = vol * system.residual(x_r, 0.0, None)[:nc][mask.u_faces].sum()
        u_rod = float(-(rod.force_per_length + f_b + f_t * V) / f_r)
        x = x + u_rod * x_r
        forces = (f_b, f_t, f_r)
    u, w, pp = system.split(x)
    pp = pp.copy()
    top_row = pp[(nz - 1) * nx:] * 1.5 - pp[(nz - 2) * nx:(nz - 1) * nx] * 0.5
    pp += P - top_row.mean()
    material = ~mask.solid_cells
    s_xz = ops.centre_from_corners @ system.shear_stress_corners(x, V)
    s_xx = system.normal_deviator_centres(x)
    p_pos = np.maximum(pp, _P_FLOOR * P)
    mu = np.sqrt(s_xx**2 + s_xz**2)[material] / p_pos[material]
    residual = float(np.abs(system.residual(x, V, body)[~np.concatenate(
        [mask.u_faces, mask.w_faces, np.ones(nc, bool)])]).max() / max(geometry.wall_pressure / geometry.d, 1e-300))
    out: dict = {"converged": residual <= RESIDUAL_TOL, "iterations": 1, "residual": residual, "n_grid": nc,
                 "fluidity_floor": floor, "floor_at_rod": floor_at_rod,
                 "tau_top": float(system.shear_stress_corners(x, V)[nz * nx:].mean()),
                 "planar_solve_seconds": planar_seconds, "planar": planar, "coupling": "frozen",
                 # where the stress ratio around the rod exceeds mu_s the frozen fluidity is not
                 # self-consistent (the coupled solve would fluidise there): reported, not hidden
                 "mu_max": float(mu.max()), "p_min": float(pp[material].min())}
    _rod_outputs(out, system, x, V, rod, grid, mask, cell_length_x, V, forces, u_rod)
    out["fields"] = _fields(grid, mask, u, w, pp, g, mu, V if rod is None else u_rod)
    out["solve_seconds"] = time.perf_counter() - t0
    return out


def _shear_flux(s_xz: np.ndarray, g: np.ndarray, p: np.ndarray, material: np.ndarray) -> float:
    """Sum over material cells of T_xz g / p (proportional to the x-averaged velocity gained
    across the layer, du/dz = T_xz g / p in planar flow)."""
    return float(np.sum((s_xz * g / p)[material]))


def _fields(grid: MacGrid, mask: RodMask, u: np.ndarray, w: np.ndarray, p: np.ndarray, g: np.ndarray,
            mu_material: np.ndarray, rod_speed: float) -> xr.Dataset:
    nx, nz = grid.nx, grid.nz
    u2 = u.reshape(nz, nx)
    ux = 0.5 * (u2 + np.roll(u2, -1, axis=1))
    w_full = np.zeros((nz + 1, nx))
    w_full[1:nz] = w.reshape(nz - 1, nx)
    uz = 0.5 * (w_full[:-1] + w_full[1:])
    solid = mask.solid_cells.reshape(nz, nx)
    mu = np.full(grid.n_cells, np.nan)
    mu[~mask.solid_cells] = mu_material
    fl = np.where(mask.solid_cells, np.nan, g)
    pr = np.where(mask.solid_cells, np.nan, p)

    def var(values: np.ndarray, units: str, name: str) -> tuple:
        return (("z", "x"), values.reshape(nz, nx), {"units": units, "long_name": name})

    return xr.Dataset(
        {
            "u_x": var(ux, "m s-1", "velocity along x (rigid rod speed inside the rod)"),
            "u_z": var(uz, "m s-1", "velocity along z"),
            "fluidity": var(fl, "s-1", "granular fluidity g (NaN inside the rod)"),
            "shear_rate": var(fl * mu, "s-1", "shear-rate magnitude g mu (NaN inside the rod)"),
            "p": var(pr, "Pa", "pressure, compressive positive (NaN inside the rod)"),
            "mu": var(mu, "1", "stress ratio tau / p (NaN inside the rod)"),
            "solid": var(solid.astype(np.int8).ravel(), "1", "1 inside the rod"),
        },
        coords={"x": ("x", grid.x_centres, {"units": "m", "long_name": "cell-centre x"}),
                "z": ("z", grid.z_centres, {"units": "m", "long_name": "cell-centre height above the bottom wall"})},
        attrs={"rod_speed": float(rod_speed), "nx": nx, "nz": nz},
    )
