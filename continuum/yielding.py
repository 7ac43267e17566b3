"""Evolution of a rate-independent critical-state layer to its steady state.

Shared by ``critical_state`` (local flow rule) and ``volume_averaged`` (flow rule averaged over a
length l). Steady planar flow has div u = 0, so the isotropic part of the flow rule forces
alpha = 1 wherever the plastic multiplier lambda > 0. With gravity the strength
S(z) = p_c(nu) sin_phi Y(alpha) of each plane differs, the velocity-driven layer carries
tau = min_z S, and only the weakest plane yields (lambda is a Dirac mass there).

The start-up transient, in a Lagrangian (solid-volume) coordinate m = int_0^z nu dz', in which p
does not change as the layer dilates: the yielding plane z* dilates or compacts at the rate
-lambda sin_phi Y'(alpha*), and the averaging spreads that volumetric rate, like the shear rate,
with the same weight G(z - z*) (G = delta for the local model; G = exp(-|z - z*| / l) for the
volume-averaged one). So d ln nu(z) = G(z - z*) d ln nu(z*): the path to steady state in packing
space is fixed by the sequence of yielding planes, and the rate only sets the pace. The
evolution is integrated in the progress variable ln nu(z*), in steps of at most ``max_step``,
re-selecting the weakest plane after each step, until it is at the critical state.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .errors import ConvergenceError
from .grid import cumulative_trapezoid
from .parameters import CriticalStateParameters

_TIE_RTOL = 1e-9


@dataclass
class YieldState:
    """Steady state of the evolution.

    Attributes:
        z: node heights (m) at steady state (Lagrangian nodes move as the layer dilates).
        nu: solid fraction at the nodes.
        tau: shear stress carried (Pa), the strength of the weakest plane.
        band: index of the yielding node, or -1 when several planes tie (velocity undetermined).
        events: number of evolution steps taken.
        residual: |ln alpha| at the yielding plane(s) at the end.
    """

    z: np.ndarray
    nu: np.ndarray
    tau: float
    band: int
    events: int
    residual: float


def evolve(z0: np.ndarray, nu0: np.ndarray, p: np.ndarray, params: CriticalStateParameters,
           spread: Callable[[np.ndarray, float], np.ndarray] | None, model: str,
           max_step: float = 2e-3, max_events: int = 20000, tol: float = 1e-12,
           case: str | None = None) -> YieldState:
    """Run the start-up transient to steady state.

    Args:
        z0, nu0: initial node heights (m) and packing.
        p: pressure at the nodes (Pa); fixed in the Lagrangian coordinate.
        spread: weight G(z, z_star) of the averaged flow rule (G(z_star) = 1), or None for the
            local flow rule (only the yielding node changes, and the layer height does not: a
            plane of zero thickness carries no volume).
        max_step: largest change of ln nu at the yielding plane per step.
    """
    line = params.line
    nu = nu0.copy()
    volume = cumulative_trapezoid(nu0, z0)  # Lagrangian coordinate of each node
    z = z0.copy()
    for event in range(max_events):
        strength = params.strength(nu, p)
        j = int(np.argmin(strength))
        ties = np.flatnonzero(strength <= strength[j] + _TIE_RTOL * abs(strength[j]))
        log_alpha = np.log(p[ties] / line.p_c(nu[ties]))
        residual = float(np.max(np.abs(log_alpha)))
        if residual <= tol:
            band = j if ties.size == 1 else -1
            return YieldState(z, nu, float(strength[j]), band, event, residual)
        if ties.size > 1 or spread is None:
            # Local yielding (or planes tied, where the yielding set is not unique): each
            # yielding plane goes to its critical packing.
            nu[ties] = line.nu_cs(p[ties])
            continue
        weight = spread(z, z[j])
        step = float(np.log(line.nu_cs(p[j]) / nu[j]))
        if np.count_nonzero(weight > 1e-12) > 1:
            # the neighbours change too: take small steps so the weakest plane is re-selected
            step = float(np.clip(step, -max_step, max_step))
        nu = nu * np.exp(step * weight)
        z = cumulative_trapezoid(1.0 / nu, volume)
    raise ConvergenceError(model, residual, f"no steady state after {max_events} yield events", case)


def exponential_spread(length: float) -> Callable[[np.ndarray, float], np.ndarray]:
    """G(z, z*) = exp(-|z - z*| / l), set to exactly 0 below e^-600 (no underflow)."""
    def weight(z: np.ndarray, z_star: float) -> np.ndarray:
        x = -np.abs(z - z_star) / length
        return np.where(x < -600.0, 0.0, np.exp(np.maximum(x, -600.0)))
    return weight
