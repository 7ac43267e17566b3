"""Yield-stress flow around the rod in 2D: the law and the discrete equations shared by local
mu(I), critical state and the volume-averaged model (docs/intruder_models.md).

All three are one law on the MAC grid of ``mac.py``, with the deviatoric stress along the
(averaged) plastic rate B:

    T' = 2 eta B,   eta = Y(p) / |B|_eps + eta_v(|B|, p),   B = D - l^2 lap D,
    |B| = (2 B':B')^(1/2) (the gammadot norm of docs/models.md; simple shear: |du/dz|),
    |B|_eps = (|B|^2 + eps^2)^(1/2)  (viscoplastic regularisation; eps -> 0 is the model),

so tau = |T'| / sqrt 2 -> Y(p) where the material flows (|B| >> eps) and tau < Y(p) where it is
rigid (|B| ~ eps, the regularised creep vanishing with eps).

- local mu(I): Y = mu_s p, eta_v = (mu_2 - mu_s) p I / (|B| (I + I_0)), I = |B| d / sqrt(p / rho_s),
  l = 0: tau = mu(I) p in the limit;
- critical state, steady (alpha = 1): Y = sin_phi p, eta_v = 0, l = 0;
- volume-averaged model (seed eqs 10-11 at alpha = 1): Y = sin_phi p, eta_v = 0, l > 0: eq 10
  is T' = 2 (p sin_phi / lambda) B and eq 11 lambda = |B|.

The averaging operator M = 1 - l^2 lap acts on each component of D on its own MAC points (D_xx,
D_zz at the cell centres, D_xz at the corners) with the 1D model's wall condition on the walls
and on the rod: they host no plastic events, so D is the free-space response of the material's,
l dD/dn = -D with n the material's outward normal (docs/models.md 4.3). Inside the rod B = D.

The walls' Navier slip (``PlanarShear.slip_length``) is in the operators of ``mac.py``: the wall
corners' du/dz (``ops.dzu``, ``ops.lift_top``) carries it into D_xz there, into B and into the
Jacobian alike; the walls' condition on D above is unchanged by it.

Pressure convention (``framework.py``): the momentum balance is solved for the Stokes pressure
pi (= sigma_zz in planar flow, P_wall on the top wall), and the laws see p = pi / r,
r = ``normal_stress_ratio``, floored at P_FLOOR of the top p (a bed carries no tension).

The equations are solved by Newton's method with their exact Jacobian (``equations``), because
the secant (Picard) iteration that the other 2D models use does not contract for a yield-stress
law: where the material flows at yield the stress is fixed and a change of eta only rescales the
rate (a neutral mode, made slowly contracting, ~ eps^2 / |B|^2, by the regularisation).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy import ndimage

from ..parameters import MuIParameters
from .mac import MacGrid, Operators, RodMask


@dataclass(frozen=True)
class PlasticLaw:
    """The yield-stress law T' = 2 eta B of the module docstring.

    Attributes:
        model: the contract's model name.
        friction: Y / p (mu_s for mu(I), sin_phi for the critical-state models).
        length: l of the averaged flow rule B = D - l^2 lap D (m); 0 for the local laws.
        mu_i: the rate-dependent part of mu(I), or None for the rate-independent laws.
    """

    model: str
    friction: float
    length: float = 0.0
    mu_i: MuIParameters | None = None

    def viscosity(self, rate: np.ndarray, p: np.ndarray, eps: float, d: float,
                  rho_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """eta (Pa s) at plastic-rate magnitude ``rate`` (s-1) and pressure ``p`` (Pa, > 0), and its
        derivatives d eta / d rate (Pa s2) and d eta / d p (s)."""
        reg = np.sqrt(rate**2 + eps**2)
        eta = self.friction * p / reg
        d_rate = -eta * rate / reg**2
        d_p = self.friction / reg
        if self.mu_i is not None:
            law = self.mu_i
            k = d * np.sqrt(rho_s)           # I = rate k / sqrt(p)
            den = rate * k + law.I_0 * np.sqrt(p)
            c = (law.mu_2 - law.mu_s) * k
            eta = eta + c * p / den
            d_rate = d_rate - c * p * k / den**2
            d_p = d_p + c * (rate * k + 0.5 * law.I_0 * np.sqrt(p)) / den**2
        return eta, d_rate, d_p


def corner_xz(grid: MacGrid) -> tuple[np.ndarray, np.ndarray]:
    """Flat arrays of the corner coordinates (m), corners (i hx, j hz), j = 0..nz."""
    x, z = np.meshgrid(np.arange(grid.nx) * grid.hx, np.arange(grid.nz + 1) * grid.hz)
    return x.ravel(), z.ravel()


def inside_rod(x: np.ndarray, z: np.ndarray, grid: MacGrid, centre: tuple[float, float] | None,
               radius: float) -> np.ndarray:
    """True for the points inside the rod (periodic in x); all False without a rod."""
    if centre is None:
        return np.zeros(x.shape, bool)
    lx = grid.nx * grid.hx
    dx = (x - centre[0] + 0.5 * lx) % lx - 0.5 * lx
    return dx**2 + (z - centre[1]) ** 2 < radius**2


def _laplacian(nx: int, nrows: int, h: tuple[float, float], solid: np.ndarray, length: float,
               wall_nodes: bool) -> sp.csr_matrix:
    """Five-point Laplacian (m-2) of a field on an nx x nrows lattice (periodic in x) with the
    wall condition l dD/dn = -D.

    ``wall_nodes``: the first and last rows lie on the walls (corners: the ghost row mirrors
    across the node, D_ghost = D_in - 2 h D_wall / l); otherwise the walls lie half a cell beyond
    the first and last rows (cell centres: D_ghost = D (2 l - h) / (2 l + h)). A neighbour inside
    the rod is a ghost of the second kind (the rod surface half way: staircase, first order).
    Rows of points inside the rod are left empty.
    """
    hx, hz = h
    i, j = np.meshgrid(np.arange(nx), np.arange(nrows))
    i, j = i.ravel(), j.ravel()
    c = j * nx + i
    rows, cols, vals = [], [], []
    diag = np.zeros(c.size)
    for nb_i, nb_j, hh in (((i + 1) % nx, j, hx), ((i - 1) % nx, j, hx), (i, j + 1, hz), (i, j - 1, hz)):
        beyond = (nb_j < 0) | (nb_j >= nrows)
        nb = np.clip(nb_j, 0, nrows - 1) * nx + nb_i
        ghost_rod = ~beyond & solid[nb]
        normal = ~beyond & ~ghost_rod
        rows.append(c[normal])
        cols.append(nb[normal])
        vals.append(np.full(int(normal.sum()), 1.0 / hh**2))
        diag[normal] -= 1.0 / hh**2
        robin_half = -2.0 / (hh * (2.0 * length + hh))  # (D_ghost - D) / h^2, surface half way
        diag[ghost_rod] += robin_half
        if wall_nodes:
            mirror = np.clip(2 * j - nb_j, 0, nrows - 1) * nx + nb_i
            rows.append(c[beyond])
            cols.append(mirror[beyond])
            vals.append(np.full(int(beyond.sum()), 1.0 / hh**2))
            diag[beyond] -= (1.0 + 2.0 * hh / length) / hh**2
        else:
            diag[beyond] += robin_half
    rows.append(c)
    cols.append(c)
    vals.append(diag)
    lap = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                        shape=(c.size, c.size))
    return (sp.diags((~solid).astype(float)) @ lap).tocsr()


def averaging_operators(grid: MacGrid, solid_cells: np.ndarray, solid_corners: np.ndarray,
                        length: float) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """(M_c, M_k) = 1 - l^2 lap on the cell centres and on the corners (identities for l = 0)."""
    nc, nk = grid.n_cells, grid.n_corners
    if length == 0.0:
        return sp.identity(nc, format="csr"), sp.identity(nk, format="csr")
    h = (grid.hx, grid.hz)
    lc = _laplacian(grid.nx, grid.nz, h, solid_cells, length, wall_nodes=False)
    lk = _laplacian(grid.nx, grid.nz + 1, h, solid_corners, length, wall_nodes=True)
    return ((sp.identity(nc) - length**2 * lc).tocsr(), (sp.identity(nk) - length**2 * lk).tocsr())


def fill_map(grid: MacGrid, solid: np.ndarray) -> sp.csr_matrix:
    """Selection matrix copying into each rod cell the nearest material cell's value."""
    nc = grid.n_cells
    if not solid.any():
        return sp.identity(nc, format="csr")
    _, (jj, ii) = ndimage.distance_transform_edt(solid.reshape(grid.nz, grid.nx), sampling=(grid.hz, grid.hx),
                                                 return_indices=True)
    src = (jj * grid.nx + ii).ravel()
    return sp.csr_matrix((np.ones(nc), (np.arange(nc), src)), shape=(nc, nc))


def wall_extrapolation(grid: MacGrid, ops: Operators) -> sp.csr_matrix:
    """Cell -> corner averaging of a pressure, with the wall corners' values extrapolated to
    the wall (1.5 p_1 - 0.5 p_2 of the two cells under it, averaged along x), second order as the
    pressure level is: the top wall's yield stress is then Y(P_wall / r), as in 1D."""
    nx, nz = grid.nx, grid.nz
    w = ops.corner_weights.tolil()
    for jc, j1, j2 in ((0, 0, 1), (nz, nz - 1, nz - 2)):
        for ic in range(nx):
            k = jc * nx + ic
            w.rows[k], w.data[k] = [], []
            for i in ((ic - 1) % nx, ic):
                w[k, j1 * nx + i] = w[k, j1 * nx + i] + 0.75
                w[k, j2 * nx + i] = w[k, j2 * nx + i] - 0.25
    return w.tocsr()


@dataclass
class Discretisation:
    """Everything of the grid and rod the equations need (fixed during a solve)."""

    grid: MacGrid
    ops: Operators
    mask: RodMask
    m_c: sp.csr_matrix          # 1 - l^2 lap at the centres
    m_k: sp.csr_matrix          # 1 - l^2 lap at the corners
    fill: sp.csr_matrix         # rod cells <- nearest material cell
    body: np.ndarray            # weight rho_s nu g at the interior w-faces (N m-3)
    has_rod: bool
    spin: object | None = None  # a model's own operators (Cosserat's ``SpinOperators``), else None

    def __post_init__(self) -> None:
        ops = self.ops
        self.bxx_u = (self.m_c @ ops.dxu).tocsr()   # B_xx per u
        self.bzz_w = (self.m_c @ ops.dzw).tocsr()   # B_zz per w
        self.bg_u = (self.m_k @ ops.dzu).tocsr()    # 2 B_xz per u
        self.bg_w = (self.m_k @ ops.dxw).tocsr()    # 2 B_xz per w
        self.bg_lift = self.m_k @ ops.lift_top      # 2 B_xz per unit top-wall speed
        self.kx = (-ops.dxw.T).tocsr()
        self.corner_pressure = wall_extrapolation(self.grid, ops)
        nc, nw = self.grid.n_cells, self.grid.n_w
        self.n = nc + nw + nc + (1 if self.has_rod else 0)


@dataclass(frozen=True)
class Scales:
    """Scales of the unknowns and of the residual rows (so the Newton norms are dimensionless)."""

    V: float       # top-wall speed (m s-1)
    P: float       # top-wall load (Pa)
    d: float       # grain diameter (m)


def equations(y: np.ndarray, disc: Discretisation, law: PlasticLaw, eps: float, top_speed: float,
              force: float | None, rod_speed: float | None, r_ratio: float, p_floor: float,
              rho_s: float, sc: Scales, jacobian: bool = True) -> dict:
    """Scaled residual (and Jacobian) of the discrete steady equations at y = (u, w, pi[, U]).

    Rows: x and z momentum (scaled by d / P), continuity (d / V) with the pin cell's row replaced
    by the pressure level (mean pi on the top wall = P_wall, scaled by 1 / P), the rod's faces
    (u - U, w, over V), its interior pressures (pi / P), and with the rod the force balance
    (F + force of the material on the rod) / (P d), or U - U_given when ``rod_speed`` is set.
    Returns the residual, the Jacobian (CSC), and the fields of the state (rates, stresses, p).
    """
    g, ops = disc.grid, disc.ops
    nc, nw = g.n_cells, g.n_w
    u, w, pi = y[:nc], y[nc:nc + nw], y[nc + nw:2 * nc + nw]
    bxx = disc.bxx_u @ u
    bzz = disc.bzz_w @ w
    bg = disc.bg_u @ u + disc.bg_w @ w + disc.bg_lift * top_speed
    normal = 2.0 * (bxx**2 + bzz**2)
    rate_c = np.sqrt(normal + ops.centre_from_corners @ bg**2)
    rate_k = np.sqrt(ops.corner_weights @ normal + bg**2)
    p_raw = (disc.fill @ pi) / r_ratio
    floored = p_raw < p_floor
    p_c = np.where(floored, p_floor, p_raw)
    p_k = disc.corner_pressure @ p_c
    eta_c, er_c, ep_c = law.viscosity(rate_c, p_c, eps, sc.d, rho_s)
    eta_k, er_k, ep_k = law.viscosity(rate_k, p_k, eps, sc.d, rho_s)
    t_xx, t_zz, t_xz = 2.0 * eta_c * bxx, 2.0 * eta_c * bzz, eta_k * bg
    r_u = -ops.dxu.T @ t_xx + ops.kz @ t_xz + ops.dxu.T @ pi
    r_w = disc.kx @ t_xz - ops.dzw.T @ t_zz + ops.dzw.T @ pi - disc.body
    out = {"rate_c": rate_c, "rate_k": rate_k, "p": p_raw, "p_eff": p_c, "eta_c": eta_c, "eta_k": eta_k,
           "t_xx": t_xx, "t_xz_k": t_xz, "bg": bg, "floored": floored}
    if not jacobian:
        out.update(close_system(y, disc, r_u, r_w, force, rod_speed, sc))
        return out

    diag = sp.diags
    cw, cfc = ops.corner_weights, ops.centre_from_corners
    inv_c = 1.0 / np.maximum(rate_c, 1e-300)
    inv_k = 1.0 / np.maximum(rate_k, 1e-300)
    # d rate / d (u, w)
    rc_u = diag(inv_c) @ (diag(2.0 * bxx) @ disc.bxx_u + cfc @ diag(bg) @ disc.bg_u)
    rc_w = diag(inv_c) @ (diag(2.0 * bzz) @ disc.bzz_w + cfc @ diag(bg) @ disc.bg_w)
    rk_u = diag(inv_k) @ (cw @ diag(2.0 * bxx) @ disc.bxx_u + diag(bg) @ disc.bg_u)
    rk_w = diag(inv_k) @ (cw @ diag(2.0 * bzz) @ disc.bzz_w + diag(bg) @ disc.bg_w)
    dp_c = diag(np.where(floored, 0.0, 1.0 / r_ratio)) @ disc.fill      # d p_c / d pi
    dp_k = disc.corner_pressure @ dp_c
    ec_u, ec_w, ec_p = diag(er_c) @ rc_u, diag(er_c) @ rc_w, diag(ep_c) @ dp_c
    ek_u, ek_w, ek_p = diag(er_k) @ rk_u, diag(er_k) @ rk_w, diag(ep_k) @ dp_k
    txx_u = diag(2.0 * eta_c) @ disc.bxx_u + diag(2.0 * bxx) @ ec_u
    txx_w = diag(2.0 * bxx) @ ec_w
    txx_p = diag(2.0 * bxx) @ ec_p
    tzz_u = diag(2.0 * bzz) @ ec_u
    tzz_w = diag(2.0 * eta_c) @ disc.bzz_w + diag(2.0 * bzz) @ ec_w
    tzz_p = diag(2.0 * bzz) @ ec_p
    txz_u = diag(eta_k) @ disc.bg_u + diag(bg) @ ek_u
    txz_w = diag(eta_k) @ disc.bg_w + diag(bg) @ ek_w
    txz_p = diag(bg) @ ek_p
    ju_u = -ops.dxu.T @ txx_u + ops.kz @ txz_u
    ju_w = -ops.dxu.T @ txx_w + ops.kz @ txz_w
    ju_p = -ops.dxu.T @ txx_p + ops.kz @ txz_p + ops.dxu.T
    jw_u = disc.kx @ txz_u - ops.dzw.T @ tzz_u
    jw_w = disc.kx @ txz_w - ops.dzw.T @ tzz_w
    jw_p = disc.kx @ txz_p - ops.dzw.T @ tzz_p + ops.dzw.T
    out.update(close_system(y, disc, r_u, r_w, force, rod_speed, sc, ([ju_u, ju_w, ju_p], [jw_u, jw_w, jw_p])))
    return out


def close_system(y: np.ndarray, disc: Discretisation, r_u: np.ndarray, r_w: np.ndarray, force: float | None,
                 rod_speed: float | None, sc: Scales, blocks: tuple[list, list] | None = None,
                 extra: tuple[np.ndarray, sp.spmatrix | None] | None = None) -> dict:
    """The scaled residual (and Jacobian) of a model's momentum rows closed by the shared ones.

    ``r_u``, ``r_w``: the unconstrained x and z momentum residuals div T - rho g (Pa m-1) at the
    u- and w-faces; ``blocks``: their Jacobians as lists of column blocks over the field unknowns
    (u, w, pi, then the model's own), or None for the residual alone; ``extra``: the model's own
    rows (scaled, their constraints included) and their Jacobian over the same columns. Adds
    continuity (d / V), the pressure level on the top wall (1 / P), the rod's rigid faces and
    pinned cells, and the rod's force balance or driven speed (the last unknown, U, when there is
    a rod). Returns ``residual``, ``rod_force`` (N m-1, the material's force on the rod along x,
    from the unconstrained x rows over its faces) and, with ``blocks``, ``jacobian`` (CSC).
    """
    g, ops, mask = disc.grid, disc.ops, disc.mask
    nc, nw, nx, nz = g.n_cells, g.n_w, g.nx, g.nz
    u, w, pi = y[:nc], y[nc:nc + nw], y[nc + nw:2 * nc + nw]
    U = y[-1] if disc.has_rod else 0.0
    r_c = ops.dxu @ u + ops.dzw @ w
    res_u, res_w, res_c = r_u * sc.d / sc.P, r_w * sc.d / sc.P, r_c * sc.d / sc.V
    vol = g.hx * g.hz
    pin = (nz - 1) * nx
    top = slice((nz - 1) * nx, nz * nx)
    below = slice((nz - 2) * nx, (nz - 1) * nx)
    level = (np.mean(1.5 * pi[top] - 0.5 * pi[below]) - sc.P) / sc.P
    res_u = np.where(mask.u_faces, (u - U) / sc.V, res_u)
    res_w = np.where(mask.w_faces, w / sc.V, res_w)
    res_c = np.where(mask.pinned_cells, pi / sc.P, res_c)
    res_c[pin] = level
    parts = [res_u, res_w, res_c] + ([extra[0]] if extra is not None else [])
    rod_force = float(vol * r_u[mask.u_faces].sum()) if disc.has_rod else 0.0
    if disc.has_rod:
        parts.append(np.array([(U - rod_speed) / sc.V if rod_speed is not None
                               else (force + rod_force) / (sc.P * sc.d)]))
    out = {"residual": np.concatenate(parts), "rod_force": rod_force}
    if blocks is None:
        return out

    diag = sp.diags
    ju, jw = blocks
    nf = sum(b.shape[1] for b in ju)  # field unknowns (U excluded)
    jmom = sp.bmat([ju, jw], format="csr")
    jcon = sp.hstack([ops.dxu, ops.dzw, sp.csr_matrix((nc, nf - nc - nw))], format="csr")
    jac = sp.vstack([jmom * (sc.d / sc.P), jcon * (sc.d / sc.V)], format="csr")
    # constraint rows
    n3 = 2 * nc + nw
    constrained = np.concatenate([mask.u_faces, mask.w_faces, mask.pinned_cells])
    constrained[nc + nw + pin] = True
    scale_c = np.concatenate([np.full(nc, 1.0 / sc.V), np.full(nw, 1.0 / sc.V), np.full(nc, 1.0 / sc.P)])
    scale_c[nc + nw + pin] = 0.0  # the pin cell's row is the pressure level
    ident = diag(np.where(constrained, scale_c, 0.0), 0, shape=(n3, nf))
    cols = np.concatenate([nc + nw + np.arange(top.start, top.stop), nc + nw + np.arange(below.start, below.stop)])
    level = sp.csr_matrix((np.concatenate([np.full(nx, 1.5 / (nx * sc.P)), np.full(nx, -0.5 / (nx * sc.P))]),
                           (np.full(2 * nx, nc + nw + pin), cols)), shape=(n3, nf))
    jac = (diag((~constrained).astype(float)) @ jac + ident + level).tocsr()
    if extra is not None:
        jac = sp.vstack([jac, extra[1]], format="csr")
    if disc.has_rod:
        u_col = np.zeros(nf)
        u_col[:nc][mask.u_faces] = -1.0 / sc.V
        if rod_speed is not None:
            last = sp.csr_matrix(([1.0 / sc.V], ([0], [nf])), shape=(1, nf + 1))
        else:
            sel = sp.csr_matrix((np.ones(int(mask.u_faces.sum())), (np.zeros(int(mask.u_faces.sum()), int),
                                                                     np.flatnonzero(mask.u_faces))), shape=(1, nc))
            row = sel @ sp.hstack(ju) * (vol / (sc.P * sc.d))
            last = sp.hstack([row, sp.csr_matrix((1, 1))])
        jac = sp.vstack([sp.hstack([jac, sp.csr_matrix(u_col[:, None])]), last], format="csc")
    out["jacobian"] = jac.tocsc()
    return out
