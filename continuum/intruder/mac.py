"""Staggered (MAC) finite-volume grid on the periodic x-z cell, and the variable-viscosity Stokes
operator with a rigid rod and rigid walls.

Layout: cells (i, j), i = 0..nx-1 (periodic in x), j = 0..nz-1 (bottom to top), centres at
((i + 1/2) hx, (j + 1/2) hz) carry the pressure p, the viscosity and the fluidity;
u-faces at (i hx, (j + 1/2) hz); w-faces at ((i + 1/2) hx, j hz) for j = 1..nz-1 (w = 0 on the
walls); corners (i hx, j hz), j = 0..nz, carry the shear stress. Flat index = j * nx + i.

Equations (incompressible, inertia neglected, tensile-positive Cauchy stress
T = -p I + 2 eta D; p is the compressive-positive pressure):
    div(2 eta D) - grad p - rho g e_z = 0,   div u = 0.
Walls: w = 0, and along x the Navier (Robin) condition of ``PlanarShear.slip_length`` b,
u = U_top - b du/dz at z = H and u = U_bottom (= 0) + b du/dz at z = 0 (b = 0: no slip), imposed
through the ghost u-row beyond each wall (``build_operators``).
Rod: the faces whose position lies inside the rod are set to the rigid motion (U_rod, 0);
pressure cells whose four faces are all rod faces are pinned (their pressure does not act on
the fluid, and the forces summed over the rod do not depend on it).
Second order in the fluid; the rod boundary is a staircase (first order in its position).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from .scene import RodIntruder

#: SuperLU's column ordering of the Stokes system (``assemble``): minimum degree on A^T A. On a
#: default NGF system it factorises in 0.6 of COLAMD's time (scipy's default) with 12 % less fill,
#: to the same residual; the default's NGF nominal job took 0.88 of the CPU, its speeds the same to
#: 1e-11 (``benchmarks/sparse_lu.py --compare stokes-colamd stokes-mmd-ata --models ngf``,
#: docs/dem_cost.md 35). A benchmark changes it to compare.
STOKES_ORDERING = "MMD_ATA"


@dataclass(frozen=True)
class MacGrid:
    """Uniform MAC grid of nx x nz cells with spacings hx, hz (m)."""

    nx: int
    nz: int
    hx: float
    hz: float

    @property
    def n_cells(self) -> int:
        return self.nx * self.nz

    @property
    def n_w(self) -> int:
        return self.nx * (self.nz - 1)

    @property
    def n_corners(self) -> int:
        return self.nx * (self.nz + 1)

    @property
    def x_centres(self) -> np.ndarray:
        return (np.arange(self.nx) + 0.5) * self.hx

    @property
    def z_centres(self) -> np.ndarray:
        return (np.arange(self.nz) + 0.5) * self.hz

    def cell_xz(self) -> tuple[np.ndarray, np.ndarray]:
        """Flat arrays of the cell-centre coordinates (m)."""
        x, z = np.meshgrid(self.x_centres, self.z_centres)
        return x.ravel(), z.ravel()


@dataclass(frozen=True)
class Operators:
    """Difference operators (CSR) and the wall lifts of the shear rate at the wall corners."""

    dxu: sp.csr_matrix   # du/dx at cell centres, (n_cells, n_u)
    dzw: sp.csr_matrix   # dw/dz at cell centres, (n_cells, n_w)
    dzu: sp.csr_matrix   # du/dz at corners (ghost-node walls with the Navier slip), (n_corners, n_u)
    dxw: sp.csr_matrix   # dw/dx at corners, (n_corners, n_w)
    kz: sp.csr_matrix    # d/dz of a corner field at u-faces, (n_u, n_corners)
    lift_top: np.ndarray  # du/dz at corners per unit top-wall speed
    lift_bottom: np.ndarray  # du/dz at corners per unit bottom-wall speed
    corner_weights: sp.csr_matrix  # cell -> corner averaging (1/4 inside, 1/2 on walls)
    centre_from_corners: sp.csr_matrix  # corner -> cell averaging (1/4 each)
    slip_length: float = 0.0  # the walls' Navier slip length b (m) built into dzu and the lifts

    def wall_velocities(self, u: np.ndarray, top_speed: float, nx: int) -> tuple[np.ndarray, np.ndarray]:
        """The grains' velocity along x in the bottom and top wall planes at the nx wall corners
        (m s-1): U_bottom + b du/dz and U_top - b du/dz with the walls' du/dz of ``dzu`` (the
        Navier condition the ghost rows impose; 0 and U_top exactly for b = 0). The bottom wall is
        at rest."""
        rate = self.dzu @ u + self.lift_top * top_speed
        return self.slip_length * rate[:nx], top_speed - self.slip_length * rate[-nx:]


def _coo(rows: list[np.ndarray], cols: list[np.ndarray], vals: list[np.ndarray], shape: tuple[int, int]) -> sp.csr_matrix:
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=shape)


def build_operators(grid: MacGrid, slip_length: float = 0.0) -> Operators:
    """The difference operators of ``grid`` with the walls' Navier slip length b (m, >= 0).

    Wall treatment (ghost u-row half a cell beyond each wall): the wall-plane velocity is the
    mean of the ghost and the first row, the wall shear rate the one-sided difference of the two,
    and the ghost is chosen so that they satisfy the Navier (Robin) condition. At the top wall,
    with u_1 the row under it, u_wall = (u_1 + u_g) / 2 = U_top - b (u_g - u_1) / hz gives
    du/dz = (U_top - u_1) / (b + hz / 2); at the bottom du/dz = (u_1 - U_bottom) / (b + hz / 2).
    With b = 0 these are the no-slip ghosts (u_g = 2 U_wall - u_1, du/dz = 2 (U_top - u_1) / hz)
    bit for bit; a profile linear in z is exact for any b.
    """
    nx, nz, hx, hz = grid.nx, grid.nz, grid.hx, grid.hz
    if not slip_length >= 0.0:
        raise ValueError(f"slip_length must be >= 0, got {slip_length!r}")
    # 1 / (b + hz / 2), written so that b = 0 gives 2 / hz exactly
    wall = 2.0 / (hz + 2.0 * slip_length)
    i, j = np.meshgrid(np.arange(nx), np.arange(nz))
    i, j = i.ravel(), j.ravel()
    c = j * nx + i
    ip = (i + 1) % nx
    nc, nw, nk = grid.n_cells, grid.n_w, grid.n_corners
    one = np.ones_like(c, dtype=float)

    dxu = _coo([c, c], [j * nx + ip, c], [one / hx, -one / hx], (nc, nc))

    up, down = j + 1 <= nz - 1, j >= 1  # w-faces above / below the cell that are interior
    dzw = _coo([c[up], c[down]], [(j[up]) * nx + i[up], (j[down] - 1) * nx + i[down]],
               [one[up] / hz, -one[down] / hz], (nc, nw))

    # corners (ic, jc), jc = 0..nz
    ic, jc = np.meshgrid(np.arange(nx), np.arange(nz + 1))
    ic, jc = ic.ravel(), jc.ravel()
    k = jc * nx + ic
    inner = (jc >= 1) & (jc <= nz - 1)
    bot, top = jc == 0, jc == nz
    ones_k = np.ones_like(k, dtype=float)
    dzu = _coo(
        [k[inner], k[inner], k[bot], k[top]],
        [jc[inner] * nx + ic[inner], (jc[inner] - 1) * nx + ic[inner], ic[bot], (nz - 1) * nx + ic[top]],
        [ones_k[inner] / hz, -ones_k[inner] / hz, wall * ones_k[bot], -wall * ones_k[top]],
        (nk, nc))
    lift_top = np.where(top, wall, 0.0)
    lift_bottom = np.where(bot, -wall, 0.0)
    im = (ic - 1) % nx
    dxw = _coo([k[inner], k[inner]],
               [(jc[inner] - 1) * nx + ic[inner], (jc[inner] - 1) * nx + im[inner]],
               [ones_k[inner] / hx, -ones_k[inner] / hx], (nk, nw))
    # d/dz of corner values at u-face (i, j): (k(i, j+1) - k(i, j)) / hz
    kz = _coo([c, c], [(j + 1) * nx + i, j * nx + i], [one / hz, -one / hz], (nc, nk))

    # cell -> corner averaging: corner (ic, jc) touches cells (ic-1, jc-1), (ic, jc-1), (ic-1, jc), (ic, jc)
    rows, cols, vals = [], [], []
    for di in (-1, 0):
        for dj in (-1, 0):
            jj = jc + dj
            ok = (jj >= 0) & (jj <= nz - 1)
            weight = np.where(inner, 0.25, 0.5)
            rows.append(k[ok])
            cols.append(jj[ok] * nx + (ic[ok] + di) % nx)
            vals.append(weight[ok])
    corner_weights = _coo(rows, cols, vals, (nk, nc))
    rows, cols, vals = [], [], []
    for di in (0, 1):
        for dj in (0, 1):
            rows.append(c)
            cols.append((j + dj) * nx + (i + di) % nx)
            vals.append(0.25 * one)
    centre_from_corners = _coo(rows, cols, vals, (nc, nk))
    return Operators(dxu, dzw, dzu, dxw, kz, lift_top, lift_bottom, corner_weights, centre_from_corners,
                     float(slip_length))


@dataclass(frozen=True)
class RodMask:
    """Which unknowns belong to the rigid rod (all empty when there is no rod)."""

    u_faces: np.ndarray   # bool, n_u
    w_faces: np.ndarray   # bool, n_w
    pinned_cells: np.ndarray  # bool, n_cells: all four faces in the rod
    solid_cells: np.ndarray   # bool, n_cells: centre inside the rod (excluded from the fluidity)


def rod_mask(grid: MacGrid, rod: RodIntruder | None, x_centre: float) -> RodMask:
    nx, nz, hx, hz = grid.nx, grid.nz, grid.hx, grid.hz
    if rod is None:
        f = np.zeros(grid.n_cells, bool)
        return RodMask(f.copy(), np.zeros(grid.n_w, bool), f.copy(), f.copy())
    lx = nx * hx

    def inside(x: np.ndarray, z: np.ndarray) -> np.ndarray:
        dx = (x - x_centre + 0.5 * lx) % lx - 0.5 * lx  # periodic distance
        return dx**2 + (z - rod.depth_from_bottom) ** 2 < rod.radius**2

    xu, zu = np.meshgrid(np.arange(nx) * hx, grid.z_centres)
    u_faces = inside(xu.ravel(), zu.ravel())
    xw, zw = np.meshgrid(grid.x_centres, np.arange(1, nz) * hz)
    w_faces = inside(xw.ravel(), zw.ravel())
    xc, zc = grid.cell_xz()
    solid = inside(xc, zc)
    i, j = np.meshgrid(np.arange(nx), np.arange(nz))
    i, j = i.ravel(), j.ravel()
    east = u_faces[j * nx + (i + 1) % nx]
    west = u_faces[j * nx + i]
    w_full = np.zeros((nz + 1) * nx, bool)
    w_full[nx:nz * nx] = w_faces
    north = w_full[(j + 1) * nx + i]
    south = w_full[j * nx + i]
    pinned = east & west & north & south
    return RodMask(u_faces, w_faces, pinned, solid)


@dataclass
class StokesSystem:
    """The assembled, factorised Stokes system for one viscosity field."""

    grid: MacGrid
    ops: Operators
    mask: RodMask
    matrix: sp.csr_matrix      # unconstrained operator rows (for forces)
    eta_corner: np.ndarray
    eta_centre: np.ndarray
    lu: object
    pin_row: int
    constrained_matrix: sp.csr_matrix | None = None  # the factorised matrix (for refinement)

    @property
    def n_u(self) -> int:
        return self.grid.n_cells

    def unconstrained_rhs(self, top_speed: float, body_force_z: np.ndarray | None) -> np.ndarray:
        """Right-hand side of the unconstrained rows: wall lift and gravity."""
        g, ops = self.grid, self.ops
        b = np.zeros(g.n_cells + g.n_w + g.n_cells)
        b[: g.n_cells] = -(ops.kz @ (self.eta_corner * ops.lift_top)) * top_speed
        if body_force_z is not None:
            b[g.n_cells: g.n_cells + g.n_w] = body_force_z
        return b

    def solve(self, top_speed: float, rod_speed: float, body_force_z: np.ndarray | None) -> np.ndarray:
        """Velocity-pressure vector for given top-wall and rod speeds (m s-1) and body force."""
        return self.solve_rhs(self.unconstrained_rhs(top_speed, body_force_z), rod_speed)

    def solve_rhs(self, b: np.ndarray, rod_speed: float) -> np.ndarray:
        """Velocity-pressure vector for the unconstrained right-hand side ``b`` (momentum rows in
        Pa m-1, continuity rows in s-1; the rows of rod unknowns and of the pressure pin are
        overwritten by the rod's rigid motion and zero)."""
        g, m = self.grid, self.mask
        b = np.array(b, dtype=float, copy=True)
        nc, nw = g.n_cells, g.n_w
        b[:nc][m.u_faces] = rod_speed
        b[nc:nc + nw][m.w_faces] = 0.0
        b[nc + nw:][m.pinned_cells] = 0.0
        b[self.pin_row] = 0.0
        x = self.lu.solve(b)
        if self.constrained_matrix is not None:
            # One step of iterative refinement: with the viscosity spanning ten decades (creep
            # below the shear band) the plain LU solve leaves round-off flows (du/dx ~ 1e-8 s-1
            # where it must vanish) whose stress 2 eta du/dx, times a viscosity of 1e10 Pa s,
            # shifts the pressure by tens of Pa; one refinement step removes 5 decades of it.
            x += self.lu.solve(b - self.constrained_matrix @ x)
        return x

    def residual(self, x: np.ndarray, top_speed: float, body_force_z: np.ndarray | None) -> np.ndarray:
        """Unconstrained momentum residual div T (+ body force), per unit volume (Pa m-1)."""
        return self.matrix @ x - self.unconstrained_rhs(top_speed, body_force_z)

    def split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        nc, nw = self.grid.n_cells, self.grid.n_w
        return x[:nc], x[nc:nc + nw], x[nc + nw:]

    def shear_stress_corners(self, x: np.ndarray, top_speed: float) -> np.ndarray:
        """T_xz at the corners (Pa, tensile-positive; on the top wall it is the drive tau)."""
        u, w, _ = self.split(x)
        ops = self.ops
        return self.eta_corner * (ops.dzu @ u + ops.lift_top * top_speed + ops.dxw @ w)

    def normal_deviator_centres(self, x: np.ndarray) -> np.ndarray:
        """T'_xx = 2 eta du/dx at the cell centres (Pa; T'_zz = -T'_xx)."""
        u, _, _ = self.split(x)
        return 2.0 * self.eta_centre * (self.ops.dxu @ u)


def wall_fluidity(grid: MacGrid, corner: np.ndarray, cells: np.ndarray, slip_length: float) -> np.ndarray:
    """``corner`` (1/eta at the corners, the cells' averages) with the wall corners' values moved
    to the walls for the Navier slip length b (m).

    The wall layer's compliance is (b + hz / 2) / eta_wall: the slip b over the viscosity in the
    wall plane plus the half cell to the first u-row. Each wall corner's f = 1/eta is the
    geometric interpolation f_1^(1 - theta) f_w^theta, theta = b / (b + hz / 2), between the
    first row's f_1 (the two cells beside the corner) and its log-linear extrapolation to the
    wall f_w = f_1 (f_1 / f_2)^(1/2) (f_2 the second row's): second order for the slip as for the
    half cell, exact for an exponential creep, positive, and f_1 itself as b -> 0.
    """
    nx, nz = grid.nx, grid.nz
    theta = slip_length / (slip_length + 0.5 * grid.hz)
    out = np.array(corner, dtype=float, copy=True)
    f = cells.reshape(nz, nx)
    for k0, j1, j2 in ((0, 0, 1), (nz * nx, nz - 1, nz - 2)):
        f1 = 0.5 * (f[j1] + np.roll(f[j1], 1))  # corner ic touches cells ic - 1 and ic
        f2 = 0.5 * (f[j2] + np.roll(f[j2], 1))
        out[k0:k0 + nx] = f1 * (f1 / f2) ** (0.5 * theta)
    return out


def assemble(grid: MacGrid, ops: Operators, mask: RodMask, eta_centre: np.ndarray) -> StokesSystem:
    """Assemble and factorise the Stokes system for the viscosity eta_centre (Pa s) at the cells.

    The corner viscosity is the harmonic mean of the adjacent cells (arithmetic mean of the
    fluidity-like 1/eta), which keeps the flux right across the steep exponential variation of
    the viscosity in the creeping zone.

    With wall slip (``ops.slip_length`` b > 0) the wall corners' viscosity is moved toward the
    wall (``wall_fluidity``): the slip velocity b du/dz is set by the viscosity in the wall plane,
    and the row under it (half a cell off) would make it first order in the grid.
    """
    fluidity = ops.corner_weights @ (1.0 / eta_centre)
    if ops.slip_length > 0.0:
        fluidity = wall_fluidity(grid, fluidity, 1.0 / eta_centre, ops.slip_length)
    eta_corner = 1.0 / fluidity
    ec = sp.diags(eta_centre)
    ek = sp.diags(eta_corner)
    kx = -ops.dxw.T
    a_uu = -ops.dxu.T @ (2.0 * ec) @ ops.dxu + ops.kz @ ek @ ops.dzu
    a_uw = ops.kz @ ek @ ops.dxw
    a_wu = kx @ ek @ ops.dzu
    a_ww = kx @ ek @ ops.dxw - ops.dzw.T @ (2.0 * ec) @ ops.dzw
    matrix = sp.bmat([[a_uu, a_uw, ops.dxu.T], [a_wu, a_ww, ops.dzw.T], [ops.dxu, ops.dzw, None]],
                     format="csr")
    nc, nw = grid.n_cells, grid.n_w
    constrained = np.concatenate([mask.u_faces, mask.w_faces, mask.pinned_cells])
    # one pressure pin (the level is set afterwards from the top-wall load): a top-row cell far
    # from the rod, whose continuity equation is implied by the others
    pin_cell = (grid.nz - 1) * grid.nx + 0
    if mask.pinned_cells[pin_cell]:
        raise ValueError("the pressure pin cell lies inside the rod")
    pin_row = nc + nw + pin_cell
    constrained[pin_row] = True
    keep = sp.diags((~constrained).astype(float))
    ident = sp.diags(constrained.astype(float))
    a = (keep @ matrix + ident).tocsc()
    lu = splu(a, permc_spec=STOKES_ORDERING)
    return StokesSystem(grid, ops, mask, matrix, eta_corner, eta_centre, lu, pin_row, a.tocsr())
