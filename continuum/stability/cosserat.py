"""Cosserat critical-state plasticity (Mohan, Rao & Nott 2002; seed eqs 5-6), planar.

Unknowns (u_x, u_z, omega, nu'): omega is the particle spin about the vorticity axis, with the
sign of the half vorticity ``w = (du_x/dz - du_z/dx) / 2`` (base omega = w = gammadot/2).
Relative deformation rate ``Gamma = L - omega eps`` (eps_01 = 1 = -eps_10), which vanishes for a
rigid rotation. With the tension-positive stress ``T = -sigma`` split into the pressure, the
symmetric deviator S and the skew part A, and the couple-stress vector C (couple per area on a
face of normal j), the generalised von Mises yield surface
``tau^2 = (a1 + a2) S:S + (a1 - a2) A:A + C.C / l^2 = (p_c sin(phi) Y(alpha))^2`` and the
associated flow rule give

* ``S = tau D' / (lambda (a1 + a2))``, ``A = tau (w - omega) eps / (lambda (a1 - a2))``,
  ``C = l^2 tau grad(omega) / lambda``,
* ``lambda^2 = D':D' / (a1 + a2) + 2 (w - omega)^2 / (a1 - a2) + l^2 |grad omega|^2``,
* the pressure ``p = alpha p_c(nu)`` with ``alpha`` from the isotropic part, as in
  ``critical_state``.

Balance laws: ``rho Du/Dt = div T`` and ``rho j Domega/Dt = div C + (T_01 - T_10)`` with
``j = d^2 / 10`` (solid spheres). ``a1 + a2 = 1/2`` makes tau the shear stress in simple shear;
the split ``a1 - a2`` (weight of the skew stress) is not fixed by the seed: default 1/4
(assumption, see docs/stability.md).
"""
from __future__ import annotations

import numpy as np

from continuum.stability import base
from continuum.stability.critical_state import DEFAULT_N, DEFAULT_PC_LOG_SLOPE

_EPS2 = np.array([[0.0, 1.0], [-1.0, 0.0]])


def _stress(L, omega, nu, nu0, sin_phi, n_exp, beta, a_sym, a_skew):
    D = 0.5 * (L + np.swapaxes(L, -1, -2))
    tr = D[..., 0, 0] + D[..., 1, 1]
    Dd = D - 0.5 * tr[..., None, None] * np.eye(2)
    w = 0.5 * (L[..., 0, 1] - L[..., 1, 0])
    # the local part of lambda; grad(omega) enters it only quadratically (zero at the base state)
    lam = np.sqrt(np.sum(Dd * Dd, axis=(-1, -2)) / a_sym + 2.0 * (w - omega) ** 2 / a_skew)
    mu_b = 1.0 / (n_exp * sin_phi)
    alpha = (1.0 - mu_b * tr / lam) ** (n_exp - 1.0)
    Y = n_exp * alpha - (n_exp - 1.0) * alpha ** (n_exp / (n_exp - 1.0))
    pc = np.exp(beta * (nu - nu0))
    tau = sin_phi * pc * Y
    S = tau * Dd / (lam * a_sym)
    A = tau * (w - omega) * _EPS2 / (lam * a_skew)
    return pc * alpha * np.eye(2) - S - A  # compressive-positive sigma = -T


def growth(
    I: float, sin_phi: float, nu_c: float, l: float, a_skew: float = 0.25,
    spin_inertia: float = 0.1, n_exp: float = DEFAULT_N, pc_log_slope: float = DEFAULT_PC_LOG_SLOPE,
    K: np.ndarray = base.DEFAULT_K, theta: np.ndarray = base.DEFAULT_THETA,
) -> np.ndarray:
    """Eigenvalues s / gammadot0 of Cosserat plasticity about simple shear.

    Args:
        I: inertial number of the base shear (-), sets the inertia R = nu I^2.
        sin_phi: critical-state friction (-).
        nu_c: base solid fraction (-).
        l: Cosserat material length over d (-).
        a_skew: a1 - a2 (-), weight of the skew stress in the yield invariant (a1 + a2 = 1/2).
        spin_inertia: j / d^2 (-), 1/10 for solid spheres; 0 makes the spin quasi-static.
        n_exp, pc_log_slope: as in ``critical_state.growth``.
        K, theta: wavenumbers |k| d (nk,) and orientations (rad) (nt,).

    Returns:
        complex (nk, nt, 4): modes for (u_x, u_z, omega, nu').
    """
    a_sym = 0.5
    R = nu_c * I**2
    n, _, Kg = base.wavevectors(K, theta)
    kvec = Kg[..., None] * n
    fn = lambda L, om, nu: _stress(L, om, nu, nu_c, sin_phi, n_exp, pc_log_slope, a_sym, a_skew)  # noqa: E731
    args = [base.L0, np.array(0.5), np.array(nu_c)]
    JL, Jom, Jnu = (base.complex_step_jacobian(fn, args, w) for w in range(3))
    tau0 = sin_phi  # lambda0 = 1, p0 = 1
    shape = Kg.shape + (4, 4)
    A = np.zeros(shape, dtype=complex)
    A[..., :2, :2] = -R * base.L0 + np.einsum("ijkl,...l,...j->...ik", JL, kvec, kvec)
    A[..., :2, 2] = -1j * np.einsum("ij,...j->...i", Jom, kvec)
    A[..., :2, 3] = -1j * np.einsum("ij,...j->...i", Jnu, kvec)
    # torque (T_01 - T_10) = -(sigma_01 - sigma_10), linearised with the same Jacobians
    skew = lambda J: -(J[0, 1] - J[1, 0])  # noqa: E731
    A[..., 2, :2] = 1j * np.einsum("kl,...l->...k", skew(JL), kvec)
    A[..., 2, 2] = skew(Jom) - (l * Kg) ** 2 * tau0
    A[..., 2, 3] = skew(Jnu)
    A[..., 3, :2] = -1j * nu_c * kvec
    if spin_inertia > 0.0:
        Md = np.broadcast_to(np.diag([R, R, R * spin_inertia, 1.0]).astype(complex), shape)
        return base.schur_eigenvalues(A, None, None, None, Md)
    # quasi-static spin: omega is slaved to the torque balance, eliminated as an algebraic unknown
    d, a = [0, 1, 3], [2]
    Md = np.broadcast_to(np.diag([R, R, 1.0]).astype(complex), Kg.shape + (3, 3))
    return base.schur_eigenvalues(
        A[..., d, :][..., :, d], A[..., d, :][..., :, a], A[..., a, :][..., :, d],
        A[..., a, :][..., :, a], Md)
