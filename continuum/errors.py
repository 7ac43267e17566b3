"""Errors raised by the continuum solvers.

A solve that cannot meet its tolerance raises instead of returning a profile: a silently wrong
profile would be scored against the DEM as if it were the model's prediction.
"""
from __future__ import annotations


class ContinuumError(RuntimeError):
    """Base class of every error raised by ``continuum``."""


class ConvergenceError(ContinuumError):
    """A solver did not reach its tolerance.

    Attributes:
        model: model name (``local_mu_i``, ``ngf``, ...).
        residual: the last residual of the failed solve (dimensionless, as defined by the solver).
        case: optional label of the geometry being solved (the pipeline passes the case name).
    """

    def __init__(self, model: str, residual: float, message: str, case: str | None = None) -> None:
        self.model = model
        self.residual = float(residual)
        self.case = case
        where = f" on case {case!r}" if case else ""
        super().__init__(f"{model}{where} did not converge (residual {self.residual:.3g}): {message}")


class OutOfRangeError(ContinuumError):
    """The requested state lies outside the range where the model's laws are defined
    (for instance a wall speed that needs mu >= mu_2 in the local mu(I) law)."""

    def __init__(self, model: str, message: str, case: str | None = None) -> None:
        self.model = model
        self.case = case
        where = f" on case {case!r}" if case else ""
        super().__init__(f"{model}{where}: {message}")
