"""A MAC state carried onto another grid of the same cell (the grid study's warm start).

The staggered unknowns of ``mac.py`` are interpolated bilinearly, periodic in x, with their wall
values added as rows (u in the wall planes as the Navier condition of ``mac.build_operators`` sets
it: b du/dz on the bottom wall and the top wall's speed less b du/dz on the top, b the slip length,
so 0 and the top wall's speed without slip; w = 0 on both;
the pressure extrapolated linearly to the walls, as ``plastic2d.wall_extrapolation`` does). Inside the rod the interpolated
values are whatever the old staircase had: the solver's constraint rows set the new rod's faces to
its rigid motion at the first Newton step.
"""
from __future__ import annotations

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from .mac import MacGrid


def _periodic(values: np.ndarray, x: np.ndarray, lx: float) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``values`` (nz', nx) with the first column repeated one period on: x ascending."""
    return np.concatenate([x, [x[0] + lx]]), np.concatenate([values, values[:, :1]], axis=1)


def _interp(values: np.ndarray, x: np.ndarray, z: np.ndarray, lx: float, xq: np.ndarray, zq: np.ndarray) -> np.ndarray:
    xs, vs = _periodic(values, x, lx)
    f = RegularGridInterpolator((z, xs), vs, bounds_error=False, fill_value=None)
    xq = np.where(xq < xs[0], xq + lx, xq)
    return f(np.column_stack([zq, xq]))


def same_cell(grid_of_state: np.ndarray, grid: MacGrid) -> bool:
    """Whether a state's grid (nx, nz, hx, hz) spans the same cell as ``grid`` (to 1e-9): a state of
    another scene (a bed a fraction of a grain deeper) is no start on another grid."""
    nx, nz, hx, hz = (float(v) for v in grid_of_state)
    return bool(np.isclose(nx * hx, grid.nx * grid.hx, rtol=1e-9) and np.isclose(nz * hz, grid.nz * grid.hz, rtol=1e-9))


def regrid_state(state: dict[str, np.ndarray], old: MacGrid, new: MacGrid, top_speed: float,
                 slip_length: float = 0.0) -> dict[str, np.ndarray]:
    """``state`` (``u``, ``w``, ``pi`` flat on ``old``, ``U``; ``omega`` on the corners if there) on ``new``: same cell (nx hx, nz hz
    equal to round-off), other spacings; ``slip_length`` the walls' Navier slip length b (m). Units
    unchanged (m s-1, Pa)."""
    lx, h = old.nx * old.hx, old.nz * old.hz
    if not (np.isclose(lx, new.nx * new.hx, rtol=1e-9) and np.isclose(h, new.nz * new.hz, rtol=1e-9)):
        raise ValueError(f"regrid: cells differ ({lx:g} x {h:g} m against {new.nx * new.hx:g} x {new.nz * new.hz:g} m)")
    u = state["u"].reshape(old.nz, old.nx)
    w = state["w"].reshape(old.nz - 1, old.nx)
    pi = state["pi"].reshape(old.nz, old.nx)
    xu_old, xc_old = np.arange(old.nx) * old.hx, old.x_centres
    zu_old = np.concatenate([[0.0], old.z_centres, [h]])
    # the wall-plane velocities of the old grid's Navier ghosts: du/dz = (u_1 - 0) / (b + h / 2) at
    # the bottom, (V - u_1) / (b + h / 2) at the top (exactly 0 and V for b = 0)
    wall = 2.0 / (old.hz + 2.0 * slip_length)
    u_rows = np.vstack([slip_length * wall * u[0], u, top_speed - slip_length * wall * (top_speed - u[-1])])
    zw_old = np.arange(old.nz + 1) * old.hz
    w_rows = np.vstack([np.zeros(old.nx), w, np.zeros(old.nx)])
    p_rows = np.vstack([1.5 * pi[0] - 0.5 * pi[1], pi, 1.5 * pi[-1] - 0.5 * pi[-2]])
    xu, zu = np.meshgrid(np.arange(new.nx) * new.hx, new.z_centres)
    xw, zw = np.meshgrid(new.x_centres, np.arange(1, new.nz) * new.hz)
    xc, zc = np.meshgrid(new.x_centres, new.z_centres)
    out = {"u": _interp(u_rows, xu_old, zu_old, lx, xu.ravel(), zu.ravel()),
           "w": _interp(w_rows, xc_old, zw_old, lx, xw.ravel(), zw.ravel()),
           "pi": _interp(p_rows, xc_old, zu_old, lx, xc.ravel(), zc.ravel())}
    if "omega" in state:  # a corner field (Cosserat's spin): corners (i hx, j hz), j = 0..nz, walls included
        omega = state["omega"].reshape(old.nz + 1, old.nx)
        xk, zk = np.meshgrid(np.arange(new.nx) * new.hx, np.arange(new.nz + 1) * new.hz)
        out["omega"] = _interp(omega, xu_old, zw_old, lx, xk.ravel(), zk.ravel())
    out["U"] = np.array(state["U"], dtype=float).copy()
    return out
