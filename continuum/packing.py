"""Initial solid-fraction profiles for the rate-independent models (critical state, volume-averaged).

These models keep the packing of every plane that has not yielded, so their steady state depends
on the packing they start from (Vatsa et al. 2025). The pipeline passes the DEM's initial profile.
"""
from __future__ import annotations

from typing import Callable, Union

import numpy as np

from .geometry import PlanarShear
from .grid import hydrostatic_pressure
from .parameters import CriticalStateLine

# a callable nu(z), or sampled (z, nu) arrays interpolated linearly, or None for the default
InitialPacking = Union[Callable[[np.ndarray], np.ndarray], tuple[np.ndarray, np.ndarray], None]


def critical_packing(z: np.ndarray, geometry: PlanarShear, line: CriticalStateLine) -> np.ndarray:
    """nu(z) = nu_cs(p(z)) with p(z) the weight of that same packing: every plane at its
    critical state (alpha = 1), as left by earlier shearing at the same load.

    Fixed-point iteration: the correction shrinks by a factor kappa g rho_s H / p each pass.
    """
    nu = np.full_like(z, float(line.nu_cs(geometry.top_pressure)))
    for _ in range(200):
        nu_new = line.nu_cs(hydrostatic_pressure(z, nu, geometry))
        if np.max(np.abs(nu_new - nu)) <= 1e-15:
            return nu_new
        nu = nu_new
    raise RuntimeError("critical packing: fixed point did not converge (kappa too large?)")


def initial_packing(z: np.ndarray, geometry: PlanarShear, line: CriticalStateLine,
                    nu_initial: InitialPacking) -> np.ndarray:
    """Evaluate the initial packing on z: callable, (z, nu) samples, or None (critical packing)."""
    if nu_initial is None:
        return critical_packing(z, geometry, line)
    if callable(nu_initial):
        nu = np.asarray(nu_initial(z), dtype=float) * np.ones_like(z)
    else:
        z_data, nu_data = (np.asarray(a, dtype=float) for a in nu_initial)
        nu = np.interp(z, z_data, nu_data)
    if np.any(~np.isfinite(nu)) or np.any(nu <= 0.0) or np.any(nu >= 1.0):
        raise ValueError("initial solid fraction must lie in (0, 1)")
    return nu
