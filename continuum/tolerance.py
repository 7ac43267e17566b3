"""The solvers' one tolerance knob (``tolerance=`` of every ``solve``), for accuracy-cost sweeps.

``None`` keeps each solver's default: the wall-condition root to 4 machine epsilons (the models
solved by a root in the wall stress: local mu(I), NGF, Cosserat; ``wall_root``) and the
yield-event iteration to |ln alpha| <= 1e-12 (critical state, volume-averaged). A number is the
residual to reach instead: the relative mismatch of the wall condition (speed or spin), or the
bound on |ln alpha|. Both are relative, so one value means the same for every model.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.optimize import brentq

#: Default bound on |ln alpha| at the yielding plane of the yield-event iteration.
EVENT_TOLERANCE = 1e-12


def _checked(tolerance: float) -> float:
    if not tolerance > 0.0:
        raise ValueError(f"tolerance must be positive, got {tolerance!r}")
    return float(tolerance)


def event_tolerance(tolerance: float | None) -> float:
    """Bound on |ln alpha| that ends the yield-event iteration."""
    return EVENT_TOLERANCE if tolerance is None else _checked(tolerance)


def wall_root(mismatch: Callable[[float], float], lo: float, hi: float, tolerance: float | None,
              default_residual: float, max_iterations: int) -> tuple[float, bool, float, int]:
    """Root of a relative boundary-condition mismatch (wall speed, wall spin) in ``[lo, hi]``.

    With ``tolerance=None``: one Brent solve to 4 machine epsilons, accepted if the residual
    |mismatch| <= ``default_residual``. With a number: Brent to a relative tolerance of 1e-2 in
    the unknown, tightened a hundredfold at a time within the last bracket, until |mismatch| <=
    ``tolerance`` (the unknown's error is not the boundary condition's: where the wall speed
    rises steeply with the stress, a loose root misses it by far more than the root's tolerance).
    Returns (root, converged, residual, Brent iterations in all).
    """
    floor = 4.0 * np.finfo(float).eps
    target = default_residual if tolerance is None else _checked(tolerance)
    rtol = floor if tolerance is None else 1e-2
    iterations = 0
    while True:
        root, info = brentq(mismatch, lo, hi, xtol=1e-300, rtol=max(rtol, floor), maxiter=max_iterations,
                            full_output=True, disp=False)
        residual = abs(mismatch(root))
        iterations += int(info.iterations)
        if not info.converged or residual <= target or rtol <= floor:
            return root, bool(info.converged) and residual <= target, residual, iterations
        # Brent's root is within rtol |root| of the true one: keep that bracket when it holds.
        a, b = root - 2.0 * rtol * abs(root), root + 2.0 * rtol * abs(root)
        if lo <= a and b <= hi and mismatch(a) * mismatch(b) < 0.0:
            lo, hi = a, b
        rtol /= 100.0
