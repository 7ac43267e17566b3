"""The shape every score row shares (``scores.csv``'s columns and the case's role) and how the
uncertainty is estimated (:class:`ScoringSettings`): what every scorer of the stage writes into,
apart from any one of them."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

COLUMNS = ["case", "model", "metric", "value", "dem_noise", "n_grid", "solve_seconds", "role",
           "u_dem", "u_input", "u_num", "u_val", "dem_dof", "draws_solved", "draws_finite", "dem_noise_err",
           "dem_noise_pairs", "points", "u_input_method"]

#: ``u_input_method``: how the draws behind ``u_input`` (``draws_solved`` of them) were made: ``draws``
#: (each the model's own solve) or ``sensitivities`` (propagated from the nominal solution's speed
#: sensitivities, pipeline/models/intruder_sensitivities.py); empty where the score has no u_input.

#: ``role`` of a case: a fit where any of its runs fed the calibration, else a prediction.
ROLES = ("calibration", "held_out")


@dataclass(frozen=True)
class ScoringSettings:
    """How the uncertainty is estimated: DEM resamples per case, the master seed, the confidence."""

    dem_resamples: int = 200
    seed: int = 0
    confidence: float = 0.95

    @classmethod
    def from_config(cls, config: dict[str, Any]) -> ScoringSettings:
        section = config.get("scoring") or {}
        return cls(int(section.get("dem_resamples", cls.dem_resamples)), int(config.get("seed", 0)),
                   float(section.get("confidence", cls.confidence)))
