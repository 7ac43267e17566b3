"""The volume-averaged model around the rod in 2D (issue 43, item 3): seed eqs 10-11 at the
critical state, T' = 2 (sin_phi p / lambda) B, lambda = |B|, B = D - l^2 lap D, with the 1D
model's wall condition (l dD/dn = -D) on the walls and on the rod, regularised as
lambda_eps = (lambda^2 + eps^2)^(1/2) and taken to eps -> 0 (docs/intruder_models.md).

Plastic flow (lambda > 0) where the stress reaches the yield surface, rigid-in-the-mean
(lambda -> 0) elsewhere, where the deformation is the averaged response of the plastic zones:
around the rod these are the top wall's band and whatever zone the push itself yields.
"""
from __future__ import annotations

from ..parameters import VolumeAveragedParameters
from .plastic2d import PlasticLaw
from .yield2d import YieldRodSolver


class VolumeAveragedRodSolver(YieldRodSolver):
    """Volume-averaged plasticity (``VolumeAveragedParameters``): yield sin_phi p, averaging l."""

    model = "volume_averaged"
    params: VolumeAveragedParameters

    @property
    def law(self) -> PlasticLaw:
        return PlasticLaw(self.model, self.params.critical.sin_phi, self.params.l)
