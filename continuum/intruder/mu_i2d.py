"""Local mu(I) around the rod in 2D (issue 43, item 4): a regularised viscoplastic solve.

tau = mu(I) p with T' parallel to D (Jop, Forterre & Pouliquen 2006), written as
eta = mu_s p / |D|_eps + (mu_2 - mu_s) p I / (|D| (I + I_0)), I = |D| d / sqrt(p / rho_s): the
static zone (mu < mu_s) is rigid in the limit eps -> 0, and the rod's speed comes from its force
balance. Equations, wall conditions and the regularisation sequence: docs/intruder_models.md;
numerics: ``plastic2d`` and ``yield2d``.
"""
from __future__ import annotations

from ..parameters import LocalMuIParameters
from .plastic2d import PlasticLaw
from .yield2d import YieldRodSolver


class MuIRodSolver(YieldRodSolver):
    """Local mu(I) (``LocalMuIParameters``): yield mu_s p plus the rate-dependent part of mu(I)."""

    model = "local_mu_i"
    params: LocalMuIParameters

    @property
    def law(self) -> PlasticLaw:
        return PlasticLaw(self.model, self.params.mu_i.mu_s, 0.0, self.params.mu_i)
