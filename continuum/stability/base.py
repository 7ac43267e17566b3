"""Shared machinery of the linear (Hadamard) stability analysis about homogeneous simple shear.

Scalings, used by every model module (see ``docs/stability.md`` for the algebra):

* lengths in grain diameters ``d``; the wavenumber ``K = |k| d``;
* times in ``1 / gammadot0`` (the base shear rate); growth rates are ``Re(s) / gammadot0``;
* stresses in the base pressure ``p0``; compressive stress positive, ``sigma = p 1 - T'`` with
  ``T'`` the tension-positive deviator;
* the base state is ``u = gammadot0 z e_x``: ``L0 = grad u = [[0, 1], [0, 0]]`` with
  ``L_ij = d u_i / d x_j`` (index 0 = x, flow; index 1 = z, gradient).

Momentum, linearised in the frame moving with the base flow at the point considered (frozen
coefficients: the base advection ``i k . U`` is a purely imaginary shift there and is dropped):
``R (s u + L0 u) = -i dsigma . k`` with the inertia number ``R = rho gammadot0^2 d^2 / p0 =
nu I^2`` (``I`` is the base inertial number, ``nu`` the base solid fraction).

Plane waves ``exp(i k . x + s t)`` with ``k = K (cos theta, sin theta)`` in the (x, z) plane.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: base velocity gradient, L0[i, j] = d u_i / d x_j in units of gammadot0
L0 = np.array([[0.0, 1.0], [0.0, 0.0]])

#: wavenumbers (K = |k| d) sampled by default; the classifier compares the two largest decades
DEFAULT_K = np.logspace(-2.0, 6.0, 33)
#: orientations theta (rad) of the wavevector, over a half turn (s(k) and s(-k) are conjugate)
DEFAULT_THETA = np.linspace(0.0, np.pi, 181)[:-1]

# complex-step size: derivatives exact to round-off with no subtractive cancellation, which matters
# because the leading-order growth coefficient is a near-cancellation at the band edges
_CSTEP = 1e-30


def wavevectors(K: FloatArray, theta: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Unit normal n (..., 2), unit tangent t (..., 2) and |k| (...,) on the (K, theta) grid.

    Shapes: K (nk,), theta (nt,) -> n, t (nk, nt, 2), Kgrid (nk, nt).
    """
    Kg, Tg = np.meshgrid(np.asarray(K, float), np.asarray(theta, float), indexing="ij")
    n = np.stack([np.cos(Tg), np.sin(Tg)], axis=-1)
    t = np.stack([-np.sin(Tg), np.cos(Tg)], axis=-1)
    return n, t, Kg


def complex_step_jacobian(
    fn: Callable[..., np.ndarray], args: list[np.ndarray], which: int
) -> np.ndarray:
    """Jacobian of ``fn(*args)`` with respect to ``args[which]`` by the complex step.

    ``fn`` must be complex-analytic near the base point (no abs, no max). Returns an array of
    shape ``out.shape + arg.shape``.
    """
    base = [np.asarray(a, dtype=complex) for a in args]
    x = base[which]
    out0 = np.asarray(fn(*base))
    jac = np.zeros(out0.shape + x.shape)
    for idx in np.ndindex(*x.shape) if x.shape else [()]:
        pert = list(base)
        xp = x.copy()
        xp[idx] = xp[idx] + 1j * _CSTEP
        pert[which] = xp
        jac[(...,) + idx] = np.imag(np.asarray(fn(*pert))) / _CSTEP
    return jac


def schur_eigenvalues(
    Add: np.ndarray, Ada: np.ndarray | None, Aad: np.ndarray | None, Aaa: np.ndarray | None,
    Md: np.ndarray,
) -> np.ndarray:
    """Finite eigenvalues s of ``s Md xd = Add xd + Ada xa, 0 = Aad xd + Aaa xa`` (batched).

    The algebraic unknowns ``xa`` (pressure of an incompressible model, fluidity of NGF) are
    eliminated by the Schur complement; ``Aaa`` must be invertible (it is, away from the
    degenerate orientations discussed in the docs). Shapes: (..., nd, nd), (..., nd, na),
    (..., na, nd), (..., na, na), (..., nd, nd) -> (..., nd).
    """
    red = Add
    if Ada is not None and Ada.shape[-1] > 0:
        red = Add - Ada @ np.linalg.solve(Aaa, Aad)
    return np.linalg.eigvals(np.linalg.solve(Md, red))


def max_growth(s: np.ndarray) -> np.ndarray:
    """Largest real part over the eigenvalue axis (last) and the orientation axis (second last)."""
    return np.max(np.real(s), axis=(-1, -2))


def is_well_posed(K: FloatArray, growth: FloatArray, scale: FloatArray, ratio: float = 3.0) -> bool:
    """Hadamard classification from the largest growth rate against K.

    ``growth[i]`` is max over theta and modes of Re(s) at ``K[i]`` (ascending K), ``scale[i]`` the
    largest |s| there (used as the round-off floor). Ill posed when the growth at the largest K is
    above the floor and grew by more than ``ratio`` over the last decade of K: a bounded growth
    rate saturates (ratio -> 1) while an unbounded one grows like K (ratio 10), K^2 (100) or K^4.
    """
    K = np.asarray(K, float)
    top = len(K) - 1
    below = int(np.argmin(np.abs(K - K[top] / 10.0)))
    floor = 1e-9 * np.asarray(scale, float)
    g_top, g_below = growth[top], max(growth[below], floor[below])
    if g_top <= floor[top]:
        return True
    return not g_top > ratio * g_below
