"""Local mu(I) rheology: incompressible (Barker et al. 2015) and compressible mu(I)-nu(I).

Constitutive law (dimensionless, see ``base``): ``sigma = p 1 - mu(I) p D'/|D'|`` with
``|D'| = sqrt(D':D'/2)`` (so ``gammadot = 2|D'|`` in simple shear) and
``I = 2|D'| d / sqrt(p/rho_s)``. Incompressible: ``div u = 0`` and p is a Lagrange multiplier.
Compressible: ``p`` follows from inverting ``nu = nu_c - a I``, i.e. ``p = rho_s d^2 gammadot^2
a^2 / (nu_c - nu)^2``, mass conservation ``dnu/dt = -nu div u`` closes the system; an optional
bulk friction ``mu_b`` (Heyman et al. 2017) adds ``-mu_b p div(u) / gammadot`` to the pressure.
"""
from __future__ import annotations

import numpy as np

from continuum.stability import base


def mu_of_I(I: np.ndarray | float, mu_s: float, mu_2: float, I_0: float) -> np.ndarray:
    """Jop et al. (2006) friction law mu(I) = mu_s + (mu_2 - mu_s) / (1 + I_0 / I)."""
    I = np.asarray(I)
    return mu_s + (mu_2 - mu_s) * I / (I + I_0)


def barker_criterion(I: np.ndarray | float, mu_s: float, mu_2: float, I_0: float) -> np.ndarray:
    """Closed form of Barker et al. (2015): ``4c^2 - 4c + mu^2 (1 - c/2)^2``, ill posed where > 0.

    ``c = I mu'(I) / mu``. Valid for the incompressible 2D equations (the argument of the min over
    orientations lies inside the admissible range for the Jop law).
    """
    I = np.asarray(I, float)
    mu = mu_of_I(I, mu_s, mu_2, I_0)
    c = I * (mu_2 - mu_s) * I_0 / (I + I_0) ** 2 / mu
    return 4.0 * c**2 - 4.0 * c + mu**2 * (1.0 - c / 2.0) ** 2


def _sym_dev(L: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    D = 0.5 * (L + np.swapaxes(L, -1, -2))
    tr = D[..., 0, 0] + D[..., 1, 1]
    Dd = D - 0.5 * tr[..., None, None] * np.eye(2)
    return Dd, tr


def _stress_incompressible(L, p, I_state, mu_s, mu_2, I_0):
    Dd, _ = _sym_dev(L)
    mag = np.sqrt(0.5 * np.sum(Dd * Dd, axis=(-1, -2)))  # |D'|, base value 1/2
    I = I_state * 2.0 * mag / np.sqrt(p)
    mu = mu_s + (mu_2 - mu_s) * I / (I + I_0)
    return p * np.eye(2) - (mu * p / mag) * Dd


def incompressible_growth(
    I: float, mu_s: float, mu_2: float, I_0: float, nu: float = 0.6,
    K: np.ndarray = base.DEFAULT_K, theta: np.ndarray = base.DEFAULT_THETA,
) -> np.ndarray:
    """Eigenvalues s / gammadot0 of incompressible mu(I) about simple shear at inertial number I.

    Args:
        I: base inertial number (-).
        mu_s, mu_2, I_0: friction law parameters (-).
        nu: solid fraction setting the bulk density rho = rho_s nu (-); only scales inertia.
        K: dimensionless wavenumbers |k| d, shape (nk,).
        theta: wavevector orientations from the flow direction x (rad), shape (nt,).

    Returns:
        complex array (nk, nt, 1): the single transverse mode per wavevector.
    """
    R = nu * I**2
    n, t, Kg = base.wavevectors(K, theta)
    args = [base.L0, np.array(1.0)]
    fn = lambda L, p: _stress_incompressible(L, p, I, mu_s, mu_2, I_0)  # noqa: E731
    JL = base.complex_step_jacobian(fn, args, 0)  # (2,2,2,2): d sigma_ij / d L_kl
    Jp = base.complex_step_jacobian(fn, args, 1)  # (2,2)
    # u = t u_t, dL_kl = i K t_k n_l u_t ; momentum rows projected on t (dynamic) and n (algebraic)
    dsig_du = 1j * Kg[..., None, None] * np.einsum("ijkl,...k,...l->...ij", JL, t, n)
    # -i K sigma_ij n_j projected on e
    def proj(e, dsig):
        return -1j * Kg * np.einsum("...i,...ij,...j->...", e, dsig, n)
    adv_t = -R * np.einsum("...i,ij,...j->...", t, base.L0, t)
    adv_n = -R * np.einsum("...i,ij,...j->...", n, base.L0, t)
    Add = (proj(t, dsig_du) + adv_t)[..., None, None]
    Ada = proj(t, np.broadcast_to(Jp, dsig_du.shape))[..., None, None]
    Aad = (proj(n, dsig_du) + adv_n)[..., None, None]
    Aaa = proj(n, np.broadcast_to(Jp, dsig_du.shape))[..., None, None]
    Md = np.full(Add.shape, R, dtype=complex)
    return base.schur_eigenvalues(Add, Ada, Aad, Aaa, Md)


def _stress_compressible(L, nu, I_state, mu_s, mu_2, I_0, nu_c, a, mu_b):
    Dd, tr = _sym_dev(L)
    mag = np.sqrt(0.5 * np.sum(Dd * Dd, axis=(-1, -2)))
    # p = (gammadot / I(nu))^2 in units of p0, with I(nu) = (nu_c - nu)/a and gammadot = 2|D'|
    I_nu = (nu_c - nu) / a
    p = (2.0 * mag * I_state / I_nu) ** 2
    I = I_nu  # the dilatancy law ties I to nu
    mu = mu_s + (mu_2 - mu_s) * I / (I + I_0)
    p_tot = p * (1.0 - mu_b * tr / (2.0 * mag))
    return p_tot * np.eye(2) - (mu * p / mag) * Dd


def compressible_growth(
    I: float, mu_s: float, mu_2: float, I_0: float, nu_c: float, a: float, mu_b: float = 0.0,
    K: np.ndarray = base.DEFAULT_K, theta: np.ndarray = base.DEFAULT_THETA,
) -> np.ndarray:
    """Eigenvalues s / gammadot0 of compressible mu(I)-nu(I) (nu = nu_c - a I) about simple shear.

    Unknowns (u_x, u_z, nu'); all dynamic, so three modes per wavevector. ``mu_b`` is an optional
    bulk friction (0 = the plain mu(I)-nu(I) rheology). Returns complex (nk, nt, 3).
    """
    nu0 = nu_c - a * I
    if not nu0 > 0.0:
        raise ValueError(f"nu_c - a I = {nu0!r} must be positive")
    R = nu0 * I**2
    n, _, Kg = base.wavevectors(K, theta)
    kvec = Kg[..., None] * n
    fn = lambda L, nu: _stress_compressible(L, nu, I, mu_s, mu_2, I_0, nu_c, a, mu_b)  # noqa: E731
    args = [base.L0, np.array(nu0)]
    JL = base.complex_step_jacobian(fn, args, 0)
    Jnu = base.complex_step_jacobian(fn, args, 1)
    shape = Kg.shape + (3, 3)
    A = np.zeros(shape, dtype=complex)
    # momentum: R s u_i = -R L0_ij u_j - i k_j dsigma_ij ; dsigma_ij = JL_ijkl i u_k k_l + Jnu_ij nu'
    A[..., :2, :2] = -R * base.L0 + np.einsum("ijkl,...l,...j->...ik", JL, kvec, kvec)
    A[..., :2, 2] = -1j * np.einsum("ij,...j->...i", Jnu, kvec)
    # mass: s nu' = -nu0 i k . u
    A[..., 2, :2] = -1j * nu0 * kvec
    Md = np.broadcast_to(np.diag([R, R, 1.0]).astype(complex), shape)
    return base.schur_eigenvalues(A, None, None, None, Md)
