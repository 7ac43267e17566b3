"""Non-local granular fluidity (Kamrin & Koval 2012; Henann & Kamrin 2013), incompressible.

Constitutive law (dimensionless, see ``base``): ``T' = 2 p D / g`` (so ``gammadot = g mu`` with
``mu = |T'|/p``), fluidity ``xi^2 lap g = g - g_loc`` solved quasi-statically (no time
derivative), ``g_loc = sqrt(p/(rho_s d^2)) (mu - mu_s)/(b mu)``, ``xi = A d / sqrt|mu - mu_s|``,
``b = (mu_2 - mu_s)/I_0``. The homogeneous steady state has ``g = g_loc``, hence
``mu = mu_s + b I``: the base friction is the linearised mu(I), not the Jop law.
In units of gammadot0, ``g_loc = sqrt(p) (mu - mu_s) / (b mu I)``.
"""
from __future__ import annotations

import numpy as np

from continuum.stability import base


def base_mu(I: float, mu_s: float, mu_2: float, I_0: float) -> float:
    """Stress ratio of the homogeneous NGF state at inertial number I: mu_s + b I."""
    return mu_s + (mu_2 - mu_s) / I_0 * I


def _stress(L, p, g):
    D = 0.5 * (L + np.swapaxes(L, -1, -2))
    return p * np.eye(2) - 2.0 * p * D / g


def _fluidity_residual(L, p, g, I, mu_s, b):
    # g - g_loc(mu, p); mu is the stress ratio of the current stress, |T'|/p = 2|D|/g
    D = 0.5 * (L + np.swapaxes(L, -1, -2))
    mag = np.sqrt(0.5 * np.sum(D * D, axis=(-1, -2)))
    mu = 2.0 * mag / g
    return g - np.sqrt(p) * (mu - mu_s) / (b * mu * I)


def growth(
    I: float, mu_s: float, mu_2: float, I_0: float, A: float, nu: float = 0.6,
    K: np.ndarray = base.DEFAULT_K, theta: np.ndarray = base.DEFAULT_THETA,
) -> np.ndarray:
    """Eigenvalues s / gammadot0 of NGF about simple shear at inertial number I (> 0).

    Args:
        I: base inertial number (-), sets mu = mu_s + b I and g = gammadot / mu.
        mu_s, mu_2, I_0: local-law parameters (-); b = (mu_2 - mu_s) / I_0.
        A: non-local amplitude (-); xi = A d / sqrt(mu - mu_s).
        nu: solid fraction for the bulk density (-).
        K, theta: wavenumbers |k| d (nk,) and orientations (rad) (nt,).

    Returns:
        complex (nk, nt, 1): the transverse mode (pressure and fluidity are eliminated).
    """
    b = (mu_2 - mu_s) / I_0
    mu0 = mu_s + b * I
    xi = A / np.sqrt(mu0 - mu_s)
    R = nu * I**2
    n, t, Kg = base.wavevectors(K, theta)
    args = [base.L0, np.array(1.0), np.array(1.0 / mu0)]
    sig = lambda L, p, g: _stress(L, p, g)  # noqa: E731
    res = lambda L, p, g: _fluidity_residual(L, p, g, I, mu_s, b)  # noqa: E731
    JL, Jp, Jg = (base.complex_step_jacobian(sig, args, w) for w in range(3))
    hL, hp, hg = (base.complex_step_jacobian(res, args, w) for w in range(3))

    dsig_du = 1j * Kg[..., None, None] * np.einsum("ijkl,...k,...l->...ij", JL, t, n)
    dh_du = 1j * Kg * np.einsum("kl,...k,...l->...", hL, t, n)

    def proj(e, dsig):
        return -1j * Kg * np.einsum("...i,...ij,...j->...", e, dsig, n)

    full = lambda J: np.broadcast_to(J, dsig_du.shape)  # noqa: E731
    adv_t = -R * np.einsum("...i,ij,...j->...", t, base.L0, t)
    adv_n = -R * np.einsum("...i,ij,...j->...", n, base.L0, t)
    shp = Kg.shape
    Add = (proj(t, dsig_du) + adv_t)[..., None, None]
    Ada = np.stack([proj(t, full(Jp)), proj(t, full(Jg))], axis=-1)[..., None, :]
    Aad = np.stack([proj(n, dsig_du) + adv_n, dh_du], axis=-1)[..., :, None]
    Aaa = np.empty(shp + (2, 2), dtype=complex)
    Aaa[..., 0, 0] = proj(n, full(Jp))
    Aaa[..., 0, 1] = proj(n, full(Jg))
    Aaa[..., 1, 0] = hp
    # the Laplacian of the fluidity: xi^2 lap g -> -xi^2 K^2 g' moved to the residual side
    Aaa[..., 1, 1] = hg + (xi * Kg) ** 2
    Md = np.full(Add.shape, R, dtype=complex)
    return base.schur_eigenvalues(Add, Ada, Aad, Aaa, Md)
