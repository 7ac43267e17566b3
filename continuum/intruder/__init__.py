"""The intruder scene (issue 7): a rigid rod under a constant horizontal force in the creeping
zone of the planar shear cell with gravity, and each model's steady rod speed.

Public API::

    from continuum.intruder import RodIntruder, GridOptions, intruder_speed, INTRUDER_MODELS
    result = intruder_speed("ngf", geometry, params, RodIntruder(D, z_i, F), cell_length_x)
    result.speed, result.fields  # m s-1; xr.Dataset on (z, x)

A model plugs into the 2D framework by subclassing ``RodSolver`` (framework.py) and registering
in ``INTRUDER_MODELS`` (api.py). See docs/intruder.md for the equations and what is solved.
"""
from __future__ import annotations

from .api import INTRUDER_MODELS, IntruderModel, intruder_speed
from .flow import ExtraStress, Flow, RodSolution
from .framework import RodSolver
from .local import YieldForce, yield_force
from .ngf2d import NGFRodSolver, solve_2d
from .scene import GridOptions, IntruderSpeed, RodIntruder

__all__ = ["RodIntruder", "GridOptions", "IntruderSpeed", "intruder_speed", "INTRUDER_MODELS", "IntruderModel",
           "RodSolver", "RodSolution", "Flow", "ExtraStress", "NGFRodSolver", "YieldForce", "yield_force", "solve_2d"]
