"""The rod speed's derivatives with respect to a model's parameters, at its converged solution.

For the regularised yield-stress solvers (``yield2d.YieldRodSolver``) the converged state y* of
the last regularisation stage solves R(y*; theta) = 0, so by the implicit-function theorem

    dy*/dtheta_j = -J^-1 dR/dtheta_j,      J = dR/dy at (y*, theta),

and dU/dtheta_j is the rod-speed entry of it (the last unknown). ``J`` is the Jacobian the Newton
solver assembles (one sparse LU for every parameter); dR/dtheta_j is a central difference of the
residual at the fixed state y*, each side evaluated by a solver built with the parameter moved
(so every way a parameter enters is included: the law, the averaging operators of a non-local
length, the planar solution's density). No Newton solve is repeated: the cost is one LU and
2 x (number of parameters) residual evaluations per scene, where a parameter draw costs 20-50
Newton iterations with their LUs.

The derivative is that of the converged speed at the last regularisation. Where the nominal
solution is a rigid zone's creep in the limit (``rigid_in_limit``: the reported U is 0), U stays 0
in a neighbourhood of the parameters and its derivatives are 0; whether a draw far from the
nominal values would yield is not a question a derivative answers (the caller says so).

Parameters are addressed by dotted paths into the (nested, frozen) parameter dataclasses, e.g.
``critical.sin_phi`` or ``critical.line.nu_ref`` (``parameter_values``).
"""
from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ..errors import ContinuumError
from ..geometry import PlanarShear
from .api import INTRUDER_MODELS, intruder_speed
from .scene import GridOptions, RodIntruder
from .sparse_lu import SingularMatrixError, factorise
from .yield2d import YieldRodSolver

#: Relative central-difference step of the residual's parameter derivative. The residual is
#: smooth in every parameter (the laws are smooth at the regularised state); at 1e-4 the
#: truncation error (~h^2) and the round-off (~1e-16 / h of the residual's terms) are both
#: below 1e-7 of the derivative.
RELATIVE_STEP = 1e-4
#: Relative residual the derivative's linear solve may leave (``sparse_lu``: PARDISO's refined
#: solves leave 3e-7 or less on these Jacobians; a singular one leaves order 1).
SOLVE_CHECK = 1e-6


def parameter_values(params: Any, prefix: str = "") -> dict[str, float]:
    """Every float field of a (nested) parameter dataclass by dotted path (ints and bools left out:
    they are switches, not measured values)."""
    out: dict[str, float] = {}
    for field in dataclasses.fields(params):
        value = getattr(params, field.name)
        path = f"{prefix}{field.name}"
        if dataclasses.is_dataclass(value):
            out.update(parameter_values(value, path + "."))
        elif isinstance(value, float):
            out[path] = value
    return out


def with_parameter(params: Any, path: str, value: float) -> Any:
    """A copy of ``params`` with the field at dotted ``path`` set to ``value``."""
    head, _, rest = path.partition(".")
    if not any(f.name == head for f in dataclasses.fields(params)):
        raise KeyError(f"{type(params).__name__} has no parameter {head!r} (path {path!r})")
    if rest:
        return dataclasses.replace(params, **{head: with_parameter(getattr(params, head), rest, value)})
    return dataclasses.replace(params, **{head: value})


def has_jacobian(model: str) -> bool:
    """Whether ``model``'s 2D solver is a Newton yield-stress solver (``yield2d.YieldRodSolver``):
    its derivatives come from the implicit-function theorem (``speed_sensitivities``), else from
    secants of its own solves (``speed_secants``). Raises KeyError for an unknown model."""
    solver = INTRUDER_MODELS[model].solver
    return solver is not None and issubclass(solver, YieldRodSolver)


def speed_sensitivities(model: str, geometry: PlanarShear, params: Any, intruder: RodIntruder,
                        cell_length_x: float, grid: GridOptions, state: dict[str, np.ndarray],
                        paths: list[str], case: str | None = None) -> dict[str, float]:
    """dU/dtheta (m s-1 per unit of each parameter) of ``model``'s rod speed at its converged
    ``state`` (``IntruderSpeed.state`` of a solve with ``params`` on ``grid``), for each dotted
    ``path`` of ``parameter_values``. Raises KeyError for an unknown model or path, TypeError for
    a model without a Newton solver (its derivatives need repeated solves), ValueError for a state
    of another grid."""
    if not has_jacobian(model):
        raise TypeError(f"{model}: no implicit-function sensitivities (not a Newton yield-stress solver)")
    nominal = parameter_values(params)
    unknown = [p for p in paths if p not in nominal]
    if unknown:
        raise KeyError(f"{model}: no float parameter {unknown} (known: {sorted(nominal)})")
    solver_type = INTRUDER_MODELS[model].solver
    solver = solver_type(geometry, params, cell_length_x, intruder, grid, case)
    disc = solver._discretisation()
    if state["u"].size != solver.grid.n_cells:
        raise ValueError(f"{model}: the state has {state['u'].size} cells, the grid {solver.grid.n_cells}")
    y = solver._vector(state, disc)
    eps = solver.regularisations[-1]
    ev = solver._evaluate(y, disc, eps, True)
    try:
        lu = factorise(ev["jacobian"])
    except SingularMatrixError as exc:
        raise ContinuumError(f"{model}: singular Jacobian at the converged state ({exc})") from exc
    out: dict[str, float] = {}
    for path in paths:
        value = nominal[path]
        h = RELATIVE_STEP * (abs(value) if value != 0.0 else 1.0)
        sides = []
        for v in (value + h, value - h):
            moved = solver_type(geometry, with_parameter(params, path, v), cell_length_x, intruder, grid, case)
            sides.append(moved._evaluate(y, moved._discretisation(), eps, False)["residual"])
        d_residual = (sides[0] - sides[1]) / (2.0 * h)
        try:
            out[path] = float(-lu.solve(d_residual, check=SOLVE_CHECK)[-1])
        except SingularMatrixError as exc:
            raise ContinuumError(f"{model}: singular Jacobian at the converged state ({exc})") from exc
    return out


def speed_secants(model: str, geometry: PlanarShear, params: Any, intruder: RodIntruder, cell_length_x: float,
                  grid: GridOptions, warm: Any, steps: dict[str, float], case: str | None = None) -> dict[str, float]:
    """dU/dtheta (m s-1 per unit of each parameter) as central secants over +- ``steps`` (path ->
    step, in the parameter's units), each side the model's own solve warm-started from ``warm``
    (its nominal ``IntruderSpeed``): for a model without a Newton Jacobian (NGF's fixed-point map).
    A secant over a step of the parameters' own spread is the mean slope over the draws' bulk, and
    the step keeps U's change far above the solve's tolerance (rel ~1e-3). Raises what
    ``intruder_speed`` raises for a side that has no solution."""
    nominal = parameter_values(params)
    unknown = [p for p in steps if p not in nominal]
    if unknown:
        raise KeyError(f"{model}: no float parameter {unknown} (known: {sorted(nominal)})")
    out: dict[str, float] = {}
    for path, h in steps.items():
        if not h > 0.0:
            raise ValueError(f"{model}: the secant step of {path} must be positive, got {h!r}")
        up, down = (intruder_speed(model, geometry, with_parameter(params, path, nominal[path] + sign * h), intruder,
                                   cell_length_x, grid, case=case, warm=warm).speed for sign in (1.0, -1.0))
        out[path] = (up - down) / (2.0 * h)
    return out
