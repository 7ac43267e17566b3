"""Critical-state plasticity around the rod in 2D (issue 43, item 4): the rate-independent
yield law at the critical state (alpha = 1: tau = sin_phi p, T' parallel to D, div u = 0),
regularised as eta = sin_phi p / |D|_eps and taken to eps -> 0.

What it predicts: U = 0 while the rod's push is below the load at which a plastic mechanism
through the rod forms (the regularised U vanishes with eps), a rate-independent U (a fraction
of V fixed by F, not by eps) once the mechanism is kinematically tied to the moving top wall,
and no steady state above the limit load F_lim (no stress field within the yield surface
balances the push; the solve is refused with F_lim as a number). F_lim is computed by driving the
rod at speeds much larger than V and reading the force the material resists with
(``limit_load``); docs/intruder_models.md.

Wall slip: none. The law is rate-independent and its wall layer is a band of zero width on the
top wall (the 1D solution: rigid below it), which has no finite shear rate for a Navier slip
b gammadot to act on: the band is the slip, and ``PlanarShear.slip_length`` changes nothing
(``continuum.critical_state``). The regularised walls would make the same stresses (the wall
corner's rate enters only through eta = Y / rate); they are kept without slip so that the solve
is the same for any slip length, and the reported ``top_wall_slip`` is 0 (u = V in the wall
plane, as in 1D).
"""
from __future__ import annotations

from ..parameters import CriticalStateParameters
from .plastic2d import PlasticLaw
from .yield2d import YieldRodSolver


class CriticalStateRodSolver(YieldRodSolver):
    """Local critical-state plasticity at the critical state (``CriticalStateParameters``)."""

    model = "critical_state"
    params: CriticalStateParameters

    @property
    def law(self) -> PlasticLaw:
        return PlasticLaw(self.model, self.params.sin_phi)

    @property
    def wall_slip_length(self) -> float:
        """0: the band of zero width on the wall is the slip (module docstring)."""
        return 0.0
