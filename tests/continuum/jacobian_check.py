"""The analytic Jacobian of a 2D Newton rod solver against central differences of its residual."""
from __future__ import annotations

import numpy as np


def assert_jacobian_is_the_residuals_derivative(solver, regularisations=(1e-1, 1e-3)) -> None:
    """At a state perturbed from the solver's planar start (every unknown moved by 1 % of its scale),
    for each regularisation: agreement to 1e-8 of the largest entry (central differences with steps
    of 1e-7 of each unknown's scale leave ~1e-10)."""
    disc = solver._discretisation()
    scale = solver._step_scale(disc)
    y = solver._initial(solver.planar_solution(), disc)
    y = y + np.random.default_rng(1).normal(size=y.size) * scale * 1e-2
    for eps in regularisations:
        jac = solver._evaluate(y, disc, eps, True)["jacobian"].toarray()
        fd = np.empty_like(jac)
        for i in range(y.size):
            h = 1e-7 * scale[i]
            up, down = y.copy(), y.copy()
            up[i] += h
            down[i] -= h
            fd[:, i] = (solver._evaluate(up, disc, eps, False)["residual"]
                        - solver._evaluate(down, disc, eps, False)["residual"]) / (2.0 * h)
        err = np.abs(jac - fd) * scale[None, :]
        assert err.max() <= 1e-8 * (np.abs(fd) * scale[None, :]).max()
