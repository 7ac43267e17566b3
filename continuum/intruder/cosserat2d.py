"""Cosserat plasticity around the rod in 2D (issue 43, item 5): the 1D model of ``cosserat.py``
written in the x-z plane and regularised like the other yield-stress models (``yield2d``).

Unknowns on the MAC grid of ``mac.py``: u, w, the Stokes pressure pi (p = pi / r as for every
model), and the grain spin omega (about +y, the 1D model's sign: simple shear du/dz > 0 spins the
grains at omega = du/dz / 2) at the corners. Rates:

    gammadot_s = 2 |D'|                       (the 1D gammadot = du/dz; |D'| of the symmetric part)
    gammadot_r = (du/dz - dw/dx) - 2 omega    (the 1D gammadot - 2 omega: spin relative to the vorticity)
    kappa      = grad omega                   (the 1D d omega / dz)

The 1D flow rule (gammadot = lambda s / Y, gammadot - 2 omega = lambda beta t / Y,
d omega / dz = lambda M / (l^2 Y)) with the yield surface s^2 + beta t^2 + |M|^2 / l^2 = Y^2
inverts to one scalar viscosity on a generalised rate,

    eta = Y / lambda,   lambda^2 = gammadot_s^2 + gammadot_r^2 / beta + l^2 |kappa|^2,
    T'_sym = 2 eta D',   t = eta gammadot_r / beta,   M = eta l^2 kappa,

so the stress state is on the yield surface wherever lambda > 0; regularised as
eta = Y / (lambda^2 + eps^2)^(1/2) and taken to eps -> 0 along ``yield2d``'s stages. The stress is
T = -pi I + T'_sym + t (e_z e_x - e_x e_z): the traction on a z-plane along x is s + t (the 1D
tau), on an x-plane along z s - t. Balances: div T - rho g e_z = 0 at the faces, div u = 0 at the
cells, and the moment balance div M + 2 t = 0 (the 1D dM/dz = -2 t) at the corners.

Where the spin lives and its wall conditions: omega and t at the corners (where the vorticity
and D_xz are), d omega / dx on the horizontal edges between corners and d omega / dz on the
u-faces, M there, div M back at the corners. At the walls and on the rod's corners (those inside
the rod, so the staircase surface: first order in its position, as the rod's faces) the 1D wall
condition omega = chi_w (du/dz - dw/dx) / 2 replaces the moment balance. The rod translates; it
does not turn.

Checked without the rod against the 1D solution (tests/continuum/test_intruder_cosserat.py), and
the Jacobian against finite differences.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import xarray as xr

from ..geometry import PlanarShear
from ..parameters import CosseratParameters
from .flow import Flow
from .mac import MacGrid, Operators
from .plastic2d import Discretisation, PlasticLaw, Scales, close_system, corner_xz, inside_rod
from .scene import GridOptions, RodIntruder
from .yield2d import YieldRodSolver

#: The unknowns a Cosserat state carries (``YieldRodSolver._state``).
STATE_KEYS = ("u", "w", "pi", "omega", "U")
#: The regularisations eps d / V of the continuation. Three decades further than the other
#: yield-stress models': Cosserat has no rigid zone (the 1D layer is at yield to the bottom, its
#: creep decaying over xi), so the limit is a finite creep, and the regularised floor (a viscous
#: creep ~ 10 eps d below the band) must fall under it at the rod's depth. Measured without the
#: rod (calibrated l = 1.94 d, 4 cells per d): u / V at 7.7 d below the top is 1.9e-4 at
#: eps = 1e-5 V/d and 8.7e-5 at 1e-8 (1D: 6.4e-5; at 8 cells per d 6.7e-5), at 9.7 d 6.8e-5 and
#: 2.0e-6 (1D 1.1e-6); Newton converges at every stage (60 iterations in all).
REGULARISATIONS = tuple(10.0**-k for k in range(1, 9))


@dataclass(frozen=True)
class SpinOperators:
    """Differences and averages of the corner spin (CSR), and the corners with the wall condition.

    gx: d omega / dx on the horizontal edges (edge (i, j) between corners (i, j) and (i + 1, j));
    gz: d omega / dz on the u-faces (``Operators.kz``); ex, ez: edges, u-faces -> corners
    (averages; one u-face at the walls); ax, az: corners -> edges, u-faces (averages);
    fixed: corners on the walls or inside the rod.
    """

    gx: sp.csr_matrix
    gz: sp.csr_matrix
    ex: sp.csr_matrix
    ez: sp.csr_matrix
    ax: sp.csr_matrix
    az: sp.csr_matrix
    fixed: np.ndarray


def spin_operators(grid: MacGrid, ops: Operators, solid_corners: np.ndarray) -> SpinOperators:
    """The ``SpinOperators`` of ``grid`` with the rod's corners ``solid_corners`` (bool, n_corners)."""
    nx, nz, nk = grid.nx, grid.nz, grid.n_corners
    ic, jc = np.meshgrid(np.arange(nx), np.arange(nz + 1))
    ic, jc = ic.ravel(), jc.ravel()
    k = jc * nx + ic
    east = jc * nx + (ic + 1) % nx
    west_edge = jc * nx + (ic - 1) % nx
    ones = np.ones(nk)
    gx = sp.csr_matrix((np.concatenate([ones, -ones]) / grid.hx, (np.concatenate([k, k]), np.concatenate([east, k]))),
                       shape=(nk, nk))
    ax = sp.csr_matrix((np.full(2 * nk, 0.5), (np.concatenate([k, k]), np.concatenate([k, east]))), shape=(nk, nk))
    ex = sp.csr_matrix((np.full(2 * nk, 0.5), (np.concatenate([k, k]), np.concatenate([west_edge, k]))),
                       shape=(nk, nk))
    i, j = np.meshgrid(np.arange(nx), np.arange(nz))
    i, j = i.ravel(), j.ravel()
    c = j * nx + i
    az = sp.csr_matrix((np.full(2 * c.size, 0.5), (np.concatenate([c, c]), np.concatenate([j * nx + i, (j + 1) * nx + i]))),
                       shape=(grid.n_cells, nk))
    below, above = jc >= 1, jc <= nz - 1  # the u-faces under and over a corner
    weight = np.where(below & above, 0.5, 1.0)
    rows = np.concatenate([k[below], k[above]])
    cols = np.concatenate([(jc[below] - 1) * nx + ic[below], jc[above] * nx + ic[above]])
    ez = sp.csr_matrix((np.concatenate([weight[below], weight[above]]), (rows, cols)), shape=(nk, grid.n_cells))
    fixed = (jc == 0) | (jc == nz) | solid_corners
    return SpinOperators(gx, ops.kz, ex, ez, ax, az, fixed)


@dataclass(frozen=True)
class CosseratLaw:
    """The Cosserat constants of the module docstring: beta, l (m), chi_w, and Y = friction p."""

    friction: float
    beta: float
    length: float
    wall_spin_ratio: float

    @property
    def plastic(self) -> PlasticLaw:
        """eta = Y / (lambda^2 + eps^2)^(1/2) and its derivatives (``PlasticLaw.viscosity``)."""
        return PlasticLaw("cosserat", self.friction)


def equations(y: np.ndarray, disc: Discretisation, law: CosseratLaw, eps: float, top_speed: float,
              force: float | None, rod_speed: float | None, r_ratio: float, p_floor: float,
              rho_s: float, sc: Scales, jacobian: bool = True) -> dict:
    """Scaled residual (and Jacobian) of the discrete steady equations at y = (u, w, pi, omega[, U]).

    Rows as ``plastic2d.equations`` (``close_system``), then one per corner: the moment balance
    div M + 2 t over P_wall, or on the fixed corners the wall condition
    (omega - chi_w vorticity / 2) d / V. ``disc.spin``: the ``SpinOperators``.
    """
    g, ops, spin = disc.grid, disc.ops, disc.spin
    nc, nw, nk = g.n_cells, g.n_w, g.n_corners
    u, w, pi = y[:nc], y[nc:nc + nw], y[nc + nw:2 * nc + nw]
    om = y[2 * nc + nw:2 * nc + nw + nk]
    beta, l2, chi = law.beta, law.length**2, law.wall_spin_ratio
    bxx = disc.bxx_u @ u
    bzz = disc.bzz_w @ w
    lift = disc.bg_lift * top_speed
    bg = disc.bg_u @ u + disc.bg_w @ w + lift          # 2 D_xz at the corners
    vort = disc.bg_u @ u - disc.bg_w @ w + lift        # du/dz - dw/dx at the corners
    gr = vort - 2.0 * om
    gxo, gzo = spin.gx @ om, spin.gz @ om
    extra = gr**2 / beta + l2 * (spin.ex @ gxo**2 + spin.ez @ gzo**2)
    normal = 2.0 * (bxx**2 + bzz**2)
    lam_c = np.sqrt(normal + ops.centre_from_corners @ (bg**2 + extra))
    lam_k = np.sqrt(ops.corner_weights @ normal + bg**2 + extra)
    p_raw = (disc.fill @ pi) / r_ratio
    floored = p_raw < p_floor
    p_c = np.where(floored, p_floor, p_raw)
    p_k = disc.corner_pressure @ p_c
    plastic = law.plastic
    eta_c, er_c, ep_c = plastic.viscosity(lam_c, p_c, eps, sc.d, rho_s)
    eta_k, er_k, ep_k = plastic.viscosity(lam_k, p_k, eps, sc.d, rho_s)
    t_xx, t_zz = 2.0 * eta_c * bxx, 2.0 * eta_c * bzz
    s_k, t_k = eta_k * bg, eta_k * gr / beta
    eta_x, eta_z = spin.ax @ eta_k, spin.az @ eta_k
    m_x, m_z = l2 * eta_x * gxo, l2 * eta_z * gzo
    r_u = -ops.dxu.T @ t_xx + ops.kz @ (s_k + t_k) + ops.dxu.T @ pi
    r_w = disc.kx @ (s_k - t_k) - ops.dzw.T @ t_zz + ops.dzw.T @ pi - disc.body
    r_o = -spin.gx.T @ m_x - spin.gz.T @ m_z + 2.0 * t_k
    res_o = np.where(spin.fixed, (om - 0.5 * chi * vort) * sc.d / sc.V, r_o / sc.P)
    out = {"rate_c": lam_c, "rate_k": lam_k, "p": p_raw, "p_eff": p_c, "eta_c": eta_c, "eta_k": eta_k,
           "t_xx": t_xx, "t_xz_k": s_k + t_k, "t_k": t_k, "m_x": m_x, "m_z": m_z, "bg": bg, "floored": floored}
    if not jacobian:
        out.update(close_system(y, disc, r_u, r_w, force, rod_speed, sc, extra=(res_o, None)))
        return out

    diag = sp.diags
    cw, cfc = ops.corner_weights, ops.centre_from_corners
    om_u, om_w = disc.bg_u, -disc.bg_w
    # d extra (the spin's part of lambda^2)
    de_u = diag(2.0 * gr / beta) @ om_u
    de_w = diag(2.0 * gr / beta) @ om_w
    de_o = diag(-4.0 * gr / beta) + 2.0 * l2 * (spin.ex @ diag(gxo) @ spin.gx + spin.ez @ diag(gzo) @ spin.gz)
    inv_c = diag(1.0 / np.maximum(lam_c, 1e-300))
    inv_k = diag(1.0 / np.maximum(lam_k, 1e-300))
    lc_u = inv_c @ (diag(2.0 * bxx) @ disc.bxx_u + cfc @ (diag(bg) @ disc.bg_u + 0.5 * de_u))
    lc_w = inv_c @ (diag(2.0 * bzz) @ disc.bzz_w + cfc @ (diag(bg) @ disc.bg_w + 0.5 * de_w))
    lc_o = inv_c @ cfc @ (0.5 * de_o)
    lk_u = inv_k @ (cw @ diag(2.0 * bxx) @ disc.bxx_u + diag(bg) @ disc.bg_u + 0.5 * de_u)
    lk_w = inv_k @ (cw @ diag(2.0 * bzz) @ disc.bzz_w + diag(bg) @ disc.bg_w + 0.5 * de_w)
    lk_o = inv_k @ (0.5 * de_o)
    dp_c = diag(np.where(floored, 0.0, 1.0 / r_ratio)) @ disc.fill
    dp_k = disc.corner_pressure @ dp_c
    ec = {"u": diag(er_c) @ lc_u, "w": diag(er_c) @ lc_w, "p": diag(ep_c) @ dp_c, "o": diag(er_c) @ lc_o}
    ek = {"u": diag(er_k) @ lk_u, "w": diag(er_k) @ lk_w, "p": diag(ep_k) @ dp_k, "o": diag(er_k) @ lk_o}
    # the stresses' direct dependences (at fixed eta)
    zero_c = {"u": sp.csr_matrix((nc, nc)), "w": sp.csr_matrix((nc, nw)), "p": sp.csr_matrix((nc, nc)),
              "o": sp.csr_matrix((nc, nk))}
    zero_k = {"u": sp.csr_matrix((nk, nc)), "w": sp.csr_matrix((nk, nw)), "p": sp.csr_matrix((nk, nc)),
              "o": sp.csr_matrix((nk, nk))}
    txx_0 = dict(zero_c, u=diag(2.0 * eta_c) @ disc.bxx_u)
    tzz_0 = dict(zero_c, w=diag(2.0 * eta_c) @ disc.bzz_w)
    s_0 = dict(zero_k, u=diag(eta_k) @ disc.bg_u, w=diag(eta_k) @ disc.bg_w)
    t_0 = dict(zero_k, u=diag(eta_k / beta) @ om_u, w=diag(eta_k / beta) @ om_w, o=diag(-2.0 * eta_k / beta))
    mx_0 = dict(zero_k, o=l2 * diag(eta_x) @ spin.gx)
    mz_0 = dict(zero_c, o=l2 * diag(eta_z) @ spin.gz)
    ju, jw, jo = [], [], []
    for key in ("u", "w", "p", "o"):
        txx = txx_0[key] + diag(2.0 * bxx) @ ec[key]
        tzz = tzz_0[key] + diag(2.0 * bzz) @ ec[key]
        s = s_0[key] + diag(bg) @ ek[key]
        t = t_0[key] + diag(gr / beta) @ ek[key]
        mx = mx_0[key] + l2 * diag(gxo) @ spin.ax @ ek[key]
        mz = mz_0[key] + l2 * diag(gzo) @ spin.az @ ek[key]
        ju.append(-ops.dxu.T @ txx + ops.kz @ (s + t) + (ops.dxu.T if key == "p" else 0))
        jw.append(disc.kx @ (s - t) - ops.dzw.T @ tzz + (ops.dzw.T if key == "p" else 0))
        jo.append(-spin.gx.T @ mx - spin.gz.T @ mz + 2.0 * t)
    wall = {"u": -0.5 * chi * om_u, "w": -0.5 * chi * om_w, "p": zero_k["p"], "o": sp.identity(nk)}
    free = diag(np.where(spin.fixed, 0.0, 1.0 / sc.P))
    fixed = diag(np.where(spin.fixed, sc.d / sc.V, 0.0))
    j_spin = sp.hstack([free @ jo[n] + fixed @ wall[key] for n, key in enumerate(("u", "w", "p", "o"))], format="csr")
    out.update(close_system(y, disc, r_u, r_w, force, rod_speed, sc, (ju, jw), (res_o, j_spin)))
    return out


class CosseratRodSolver(YieldRodSolver):
    """Cosserat plasticity at the critical state around the rod (``CosseratParameters``)."""

    model = "cosserat"
    params: CosseratParameters
    state_keys = STATE_KEYS

    def __init__(self, geometry: PlanarShear, params: CosseratParameters, cell_length_x: float,
                 rod: RodIntruder | None, options: GridOptions = GridOptions(), case: str | None = None,
                 regularisations: tuple[float, ...] = REGULARISATIONS, rod_speed: float | None = None) -> None:
        super().__init__(geometry, params, cell_length_x, rod, options, case, regularisations, rod_speed)

    @property
    def law(self) -> PlasticLaw:
        return PlasticLaw(self.model, self.params.critical.sin_phi)

    equations_of = staticmethod(equations)

    @property
    def residual_law(self) -> CosseratLaw:
        q = self.params
        return CosseratLaw(q.critical.sin_phi, q.beta, q.l, q.wall_spin_ratio)

    def _discretisation(self) -> Discretisation:
        disc = super()._discretisation()
        grid, rod = self.grid, self.rod
        centre = None if rod is None else (0.5 * self.cell_length_x, rod.depth_from_bottom)
        xk, zk = corner_xz(grid)
        solid_k = inside_rod(xk, zk, grid, centre, 0.0 if rod is None else rod.radius)
        disc.spin = spin_operators(grid, self.ops, solid_k)
        disc.n += grid.n_corners
        return disc

    def _split(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(u, w, pi) and omega of an unknown vector (U, if any, is its last entry)."""
        n3 = 2 * self.grid.n_cells + self.grid.n_w
        return y[:n3], y[n3:n3 + self.grid.n_corners]

    def _initial(self, planar: xr.Dataset, disc: Discretisation) -> np.ndarray:
        base = super()._initial(planar, disc)  # (u, w, pi, [U]) with ``disc.n`` entries
        n3 = 2 * self.grid.n_cells + self.grid.n_w
        _, zk = corner_xz(self.grid)
        omega = np.interp(zk, planar.z.values, planar.spin.values)
        return np.concatenate([base[:n3], omega, base[n3:n3 + 1] if disc.has_rod else []])

    def _state(self, y: np.ndarray, disc: Discretisation) -> dict[str, np.ndarray]:
        state = super()._state(y, disc)
        _, omega = self._split(y)
        return {"u": state["u"], "w": state["w"], "pi": state["pi"], "omega": omega.copy(), "U": state["U"]}

    def _vector(self, state: dict[str, np.ndarray], disc: Discretisation) -> np.ndarray:
        return np.concatenate([state["u"], state["w"], state["pi"], state["omega"],
                               state["U"][:1] if disc.has_rod else []])

    def _step_scale(self, disc: Discretisation) -> np.ndarray:
        base = super()._step_scale(disc)
        n3 = 2 * self.grid.n_cells + self.grid.n_w
        geo = self.geometry
        spin = np.full(self.grid.n_corners, geo.wall_speed / geo.d)
        return np.concatenate([base[:n3], spin, base[n3:]])

    def output_fields(self, flow: Flow, fields: dict[str, np.ndarray]) -> dict[str, tuple[np.ndarray, str, str]]:
        _, omega = self._split(flow.x)
        return {"spin": (self.ops.centre_from_corners @ omega, "s-1",
                         "grain spin about +y (omega = du/dz / 2 in simple shear; NaN inside the rod)")}
