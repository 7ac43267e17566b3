"""Cosserat plasticity around the rod (issue 43, item 5): not solved in 2D; the row stays open.

What a 2D solve needs, and where this project stops (docs/intruder_models.md, section 6). In 1D
(docs/models.md 5) the unknowns are u(z), the spin omega(z) and one couple stress M_zy, and the
whole layer sits on the yield surface s^2 + beta t^2 + M^2 / l^2 = (sin_phi p)^2 with the flow
rule fixing the rates up to the plastic multiplier lambda = gammadot. In the x-z plane around the
rod the unknowns become (u, w, omega_y, p) with a non-symmetric stress (T_xz != T_zx: the
antisymmetric part t enters the z balance through d T_xz / dx and the x balance through
d T_zx / dz) and two couple-stress components M_xy, M_zy with the moment balance
dM_xy/dx + dM_zy/dz + T_xz - T_zx = 0. The discrete pieces exist here (``plastic2d``'s Newton on
a MAC grid; the framework's ``ExtraStress`` carries a non-symmetric T), but three things a
converged, checked solve needs do not:
  1. a rate form of the yield surface with the couple stress (the regularised eta of the other
     yield-stress models has no analogue: the 1D solve integrates the Riccati equation for M
     with the whole layer at yield, tau fixed by M(H); in 2D lambda is not gammadot and the
     stress is not parallel to D when t != 0);
  2. the spin unknown and its boundary conditions on a staircase rod (the 1D wall condition
     omega = chi_w gammadot / 2 needs the vorticity on the rod's surface, where the staircase
     makes it first order and noisy);
  3. a no-rod check against the 1D solution, whose whole layer is at yield (no rigid zone), so
     the regularisation limit is a different one from the other models'.
None of the three was built in the time of issue 43: ``intruder_speed("cosserat", ...)`` raises
``NotImplementedError`` with ``WHY``, and the model's intruder row stays open (no fallback
number).
"""
from __future__ import annotations

WHY = ("cosserat is not solved in 2D around the rod: its rate form of the yield surface with the couple "
       "stress, the spin unknown with the wall spin condition on the staircase rod, and a no-rod check "
       "against the whole-layer-at-yield 1D solution are not built (continuum/intruder/cosserat2d.py); "
       "the intruder row stays open")


def solve(*args: object, **kwargs: object) -> None:
    """Always raises ``NotImplementedError`` (module docstring)."""
    raise NotImplementedError(WHY)
