"""Where the parameter draws' normal deviates come from: pseudo-random or quasi-random (Sobol).

Each draw of :mod:`pipeline.calibration.draws` asks its source for a multivariate normal (a fit's
covariance), a few scalar normals, in a fixed order, after ``start_draw()``:

- :class:`RandomSource` (``calibration.draw_sampler: random``, the default): numpy's generator,
  exactly the calls the draws always made, so every draw is bit for bit what it was;
- :class:`SobolSource` (``sobol``): each draw is one point of a scrambled Sobol sequence
  (``scipy.stats.qmc.Sobol``) in as many dimensions as a draw asks for, mapped to standard normals
  by the inverse normal CDF; a multivariate normal is ``mean + V sqrt(w) z`` with the covariance's
  eigen-decomposition (as numpy's ``method="eigh"``). A draw rejected outside the laws' domain
  takes the next point. Low-discrepancy points spread over the distribution more evenly than
  random ones, so a spread (u_input) needs fewer of them: with 2^m draws the sequence's balance
  properties hold (the first 2^m points of each scramble).
"""
from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from scipy.stats import norm, qmc

SAMPLERS = ("random", "sobol")

#: Normal deviates a draw asks for at most (mu(I) 3, nu(I) 2, the critical-state line 3,
#: sigma_zz / p 1, the non-local factors 3), with room to spare.
DIMENSIONS = 16


class NormalSource(Protocol):
    def start_draw(self) -> None: ...

    def multivariate_normal(self, mean: np.ndarray, cov: np.ndarray) -> np.ndarray: ...

    def normal(self, loc: float, scale: float) -> float: ...


class RandomSource:
    """numpy's generator, called as the draws always called it."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def start_draw(self) -> None:
        pass

    def multivariate_normal(self, mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
        return self.rng.multivariate_normal(mean, cov, method="eigh")

    def normal(self, loc: float, scale: float) -> float:
        return float(self.rng.normal(loc, scale))


class SobolSource:
    """One scrambled Sobol point per draw (module doc); ``points`` of them available in all."""

    def __init__(self, points: int, seed: int, dimensions: int = DIMENSIONS) -> None:
        m = max(1, math.ceil(math.log2(max(points, 2))))
        unit = qmc.Sobol(dimensions, scramble=True, seed=seed).random_base2(m)
        # the inverse CDF of a point on a cell's edge would be infinite: held inside (0, 1)
        self.z = norm.ppf(np.clip(unit, 1e-12, 1.0 - 1e-12))
        self.row, self.used = -1, 0

    def start_draw(self) -> None:
        self.row += 1
        if self.row >= self.z.shape[0]:
            raise ValueError(f"the Sobol sequence's {self.z.shape[0]} points are used up (rejected draws)")
        self.used = 0

    def _take(self, n: int) -> np.ndarray:
        if self.used + n > self.z.shape[1]:
            raise ValueError(f"a draw asks for more than the sequence's {self.z.shape[1]} dimensions")
        out = self.z[self.row, self.used:self.used + n]
        self.used += n
        return out

    def multivariate_normal(self, mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
        w, v = np.linalg.eigh(np.asarray(cov, dtype=float))
        z = self._take(len(mean))
        return np.asarray(mean, dtype=float) + v @ (np.sqrt(np.clip(w, 0.0, None)) * z)

    def normal(self, loc: float, scale: float) -> float:
        return float(loc + scale * self._take(1)[0])


def normal_source(sampler: str, seed: int, draws: int) -> NormalSource:
    """The source of ``calibration.draw_sampler`` (``random`` or ``sobol``) for ``draws`` draws."""
    if sampler == "random":
        return RandomSource(np.random.default_rng(seed))
    if sampler == "sobol":
        # four points a draw: room for the draws the laws' domain rejects
        return SobolSource(4 * draws, seed)
    raise ValueError(f"calibration.draw_sampler = {sampler!r}: choose one of {', '.join(SAMPLERS)}")
