"""Rate-independent critical-state plasticity (seed eqs 1-4) and its volume-averaged extension.

Constitutive law in 2D (dimensionless, see ``base``), from the extended von Mises yield
condition ``tau = p_c(nu) sin(phi) Y(alpha)``, ``tau = sqrt(sigma':sigma'/2)`` (so that tau is
the shear stress in simple shear), and the associated flow rule ``D = -lambda dF/dsigma``
(minus because stress is compressive positive; this gives dilation for alpha < 1):

* ``alpha = (1 - mu_b tr(D) / lambda)^(n - 1)``, ``mu_b = 1 / (n sin(phi))``;
* ``sigma = p_c(nu) alpha 1 - sin(phi) p_c(nu) Y(alpha) D' / |D'|``, ``lambda = 2 |D'|``.

The volume-averaged model (seed eqs 10-11) replaces ``D'``, ``tr D`` and ``lambda`` by
``(1 - l^2 lap)`` of themselves; about a homogeneous base state every rate perturbation then
carries the factor ``Lambda = 1 + (l k)^2`` (docs/stability.md), which is all that changes here.

``p_c(nu)`` enters the linearisation only through ``beta = d ln p_c / d nu`` at the base state;
the default ``beta = 35`` is the slope of ``p_c ~ (nu - 0.5) / (0.64 - nu)`` at nu = 0.6.
"""
from __future__ import annotations

import numpy as np

from continuum.stability import base

DEFAULT_N = 1.05
DEFAULT_PC_LOG_SLOPE = 1.0 / (0.6 - 0.5) + 1.0 / (0.64 - 0.6)


def _stress(L, nu, nu0, sin_phi, n_exp, beta):
    D = 0.5 * (L + np.swapaxes(L, -1, -2))
    tr = D[..., 0, 0] + D[..., 1, 1]
    Dd = D - 0.5 * tr[..., None, None] * np.eye(2)
    mag = np.sqrt(0.5 * np.sum(Dd * Dd, axis=(-1, -2)))
    mu_b = 1.0 / (n_exp * sin_phi)
    alpha = (1.0 - mu_b * tr / (2.0 * mag)) ** (n_exp - 1.0)
    Y = n_exp * alpha - (n_exp - 1.0) * alpha ** (n_exp / (n_exp - 1.0))
    pc = np.exp(beta * (nu - nu0))
    return pc * alpha * np.eye(2) - sin_phi * pc * Y * Dd / mag


def growth(
    I: float, sin_phi: float, nu_c: float, l: float = 0.0, n_exp: float = DEFAULT_N,
    pc_log_slope: float = DEFAULT_PC_LOG_SLOPE,
    K: np.ndarray = base.DEFAULT_K, theta: np.ndarray = base.DEFAULT_THETA,
) -> np.ndarray:
    """Eigenvalues s / gammadot0 of critical-state (l = 0) or volume-averaged (l > 0) plasticity.

    Args:
        I: inertial number of the base shear (-); the law is rate independent, so I only sets the
            inertia R = nu I^2 relative to the plastic stresses.
        sin_phi: critical-state friction sin(phi) (-), equal to mu of the base state.
        nu_c: base solid fraction, the critical-state value at the base pressure (-).
        l: averaging length over d (-); 0 gives the local model.
        n_exp: yield-surface exponent n > 1 (-).
        pc_log_slope: d ln p_c / d nu at nu_c (-).
        K, theta: wavenumbers |k| d (nk,) and orientations (rad) (nt,).

    Returns:
        complex (nk, nt, 3): modes for the unknowns (u_x, u_z, nu').
    """
    R = nu_c * I**2
    n, _, Kg = base.wavevectors(K, theta)
    kvec = Kg[..., None] * n
    fn = lambda L, nu: _stress(L, nu, nu_c, sin_phi, n_exp, pc_log_slope)  # noqa: E731
    args = [base.L0, np.array(nu_c)]
    JL = base.complex_step_jacobian(fn, args, 0)
    Jnu = base.complex_step_jacobian(fn, args, 1)
    Lam = 1.0 + (l * Kg) ** 2
    shape = Kg.shape + (3, 3)
    A = np.zeros(shape, dtype=complex)
    A[..., :2, :2] = -R * base.L0 + Lam[..., None, None] * np.einsum("ijkl,...l,...j->...ik", JL, kvec, kvec)
    A[..., :2, 2] = -1j * np.einsum("ij,...j->...i", Jnu, kvec)
    A[..., 2, :2] = -1j * nu_c * kvec
    Md = np.broadcast_to(np.diag([R, R, 1.0]).astype(complex), shape)
    return base.schur_eigenvalues(A, None, None, None, Md)
