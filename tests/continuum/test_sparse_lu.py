"""The 2D solvers' sparse LU (``continuum.intruder.sparse_lu``): PARDISO and SuperLU solve the same
systems, PARDISO's perturbed pivots are caught where a solve is checked, and a plastic rod solve
gives the same speed with either.

Tolerances: the systems below are well conditioned (cond < 1e4) or a saddle point made regular by
its pressure block, so a backward-stable solve leaves a relative residual of about cond x 1e-16;
1e-10 leaves room. The rod speed agrees to 1e-8 relative: every Newton stage stops at a scaled
residual of 1e-6 and a step of 1e-7 V, and the last stage's quadratic convergence leaves U
converged far below that (measured 1e-13 on the default's scenes, docs/dem_cost.md 26)."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from continuum.intruder import GridOptions, RodIntruder, intruder_speed, sparse_lu
from continuum.intruder.sparse_lu import SingularMatrixError, factorise
from continuum.parameters import VolumeAveragedParameters

from .test_intruder_yield_models import CS, GEO, LX, D


def convection_diffusion(n: int) -> sp.csr_matrix:
    """The 5-point Laplacian on an n x n grid plus an upwind convection: unsymmetric, regular."""
    one = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    upwind = sp.diags([-1.0, 1.0], [-1, 0], shape=(n, n))
    eye = sp.identity(n)
    return (sp.kron(eye, one) + sp.kron(one, eye) + 0.3 * sp.kron(eye, upwind)).tocsr()


def stokes_like(n: int) -> sp.csr_matrix:
    """[[A, B^T], [B, -delta I]]: a saddle point whose pressure block is tiny, as the plastic
    Jacobians' continuity rows (zero pivots before pivoting)."""
    a = convection_diffusion(n)
    m = a.shape[0]
    b = sp.diags([1.0, -1.0], [0, 1], shape=(m, m))
    return sp.bmat([[a, b.T], [b, -1e-8 * sp.identity(m)]]).tocsr()


@pytest.mark.parametrize("matrix", [convection_diffusion(30), stokes_like(20)], ids=["convection", "saddle"])
def test_both_backends_solve_the_same_system(matrix: sp.csr_matrix) -> None:
    rng = np.random.default_rng(7)
    rhs = rng.standard_normal(matrix.shape[0])
    solutions = {}
    for backend in sparse_lu.BACKENDS:
        x = factorise(matrix, backend).solve(rhs, check=1e-6)
        assert np.linalg.norm(matrix @ x - rhs) <= 1e-10 * np.linalg.norm(rhs), backend
        solutions[backend] = x
    assert np.allclose(solutions["pardiso"], solutions["superlu"], rtol=0.0,
                       atol=1e-8 * np.max(np.abs(solutions["superlu"])))


def test_a_singular_matrix_is_refused_by_both() -> None:
    matrix = convection_diffusion(10).tolil()
    matrix[:, 5] = 0.0  # one unknown in no equation
    matrix = matrix.tocsr()
    matrix.eliminate_zeros()
    rhs = np.ones(matrix.shape[0])
    for backend in sparse_lu.BACKENDS:  # SuperLU when it factorises, PARDISO (perturbed pivots) when checked
        with pytest.raises(SingularMatrixError):
            factorise(matrix, backend).solve(rhs, check=1e-6)


def test_a_perturbed_pivot_that_does_not_solve_is_caught() -> None:
    """A repeated equation with an inconsistent right-hand side: PARDISO perturbs the zero pivot
    and returns an x, which the check refuses (no x solves it)."""
    matrix = convection_diffusion(10).tolil()
    matrix[5, :] = matrix[4, :]
    matrix = matrix.tocsr()
    rhs = np.ones(matrix.shape[0])
    rhs[5] = 2.0
    with pytest.raises(SingularMatrixError, match="relative residual"):
        factorise(matrix, "pardiso").solve(rhs, check=1e-6)


def test_an_unknown_backend_is_named() -> None:
    with pytest.raises(ValueError, match="unknown sparse LU backend 'umfpack'"):
        factorise(sp.identity(3, format="csr"), "umfpack")


def test_a_plastic_rod_solve_gives_the_same_speed_with_either_backend(monkeypatch: pytest.MonkeyPatch) -> None:
    params = VolumeAveragedParameters(CS, 1.165 * D)
    push = 0.5 * 1.5 * (GEO.wall_pressure + 0.6 * GEO.rho_s * GEO.gravity * 5 * D) * 3 * D
    rod = RodIntruder.below_top(GEO, 3 * D, 6.5 * D, push)
    speeds = {}
    for backend in sparse_lu.BACKENDS:
        monkeypatch.setattr(sparse_lu, "DEFAULT_BACKEND", backend)
        speeds[backend] = intruder_speed("volume_averaged", GEO, params, rod, LX, GridOptions(cells_per_d=2)).speed
    assert speeds["superlu"] > 0.0
    assert speeds["pardiso"] == pytest.approx(speeds["superlu"], rel=1e-8)


def test_factors_are_released() -> None:
    """MKL holds a PARDISO factor outside Python's heap: a factorisation dropped must release it
    (a leak grew a pytest process to 11 GB). 40 factorisations of a 22 500-unknown matrix (each
    factor about 20 MB): the resident memory may grow by the allocator's slack, not by 40 factors."""
    matrix = convection_diffusion(150)
    rhs = np.ones(matrix.shape[0])

    def resident_mb() -> float:
        with open("/proc/self/statm") as statm:
            return int(statm.read().split()[1]) * 4096 / 1e6

    for _ in range(5):  # the allocator's first growth
        factorise(matrix, "pardiso").solve(rhs)
    before = resident_mb()
    for _ in range(40):
        factorise(matrix, "pardiso").solve(rhs)
    assert resident_mb() - before < 100.0


def test_a_reused_analysis_solves_as_a_fresh_one() -> None:
    """Newton's Jacobians share a stencil but not every entry (scipy drops the sums that cancel):
    a factorisation that replaces another keeps its analysis when the new matrix lies inside the
    analysed pattern (numerical phase only), analyses the union when it does not, and solves as a
    fresh factorisation would, to the systems' 1e-10 (module docstring). The one replaced is spent."""
    full = stokes_like(20)
    rng = np.random.default_rng(3)
    rhs = rng.standard_normal(full.shape[0])
    sparser = full.tolil()
    sparser[3, 4] = 0.0  # an entry of the stencil that cancels in this Jacobian
    sparser = sparser.tocsr()
    sparser.eliminate_zeros()
    assert sparser.nnz == full.nnz - 1
    first = factorise(full, "pardiso")
    assert first.analysed
    inside = factorise(sparser * 1.5, "pardiso", reuse=first)
    assert not inside.analysed  # the numerical factorisation alone
    with pytest.raises(RuntimeError, match="spent"):
        first.solve(rhs)
    x = inside.solve(rhs, check=1e-6)
    assert np.linalg.norm(1.5 * sparser @ x - rhs) <= 1e-10 * np.linalg.norm(rhs)
    # a pattern outside the analysed one: analysed again, on the union
    start = factorise(sparser, "pardiso")
    grown = factorise(full, "pardiso", reuse=start)
    assert grown.analysed
    x = grown.solve(rhs, check=1e-6)
    assert np.linalg.norm(full @ x - rhs) <= 1e-10 * np.linalg.norm(rhs)
    assert np.allclose(x, factorise(full, "superlu").solve(rhs), rtol=0.0, atol=1e-8 * np.max(np.abs(x)))
    again = factorise(sparser * 0.5, "pardiso", reuse=grown)  # inside the union now
    assert not again.analysed
    assert np.linalg.norm(0.5 * sparser @ again.solve(rhs, check=1e-6) - rhs) <= 1e-10 * np.linalg.norm(rhs)


def test_the_preconditioner_is_the_factor_without_refinement() -> None:
    """``precondition`` applies LU^-1 without PARDISO's refinement steps: on a regular system it is
    still a solve to the factor's accuracy (1e-10 here), and the factor's refinement setting is
    left as it was for the checked solves after it."""
    matrix = convection_diffusion(30)
    rhs = np.random.default_rng(5).standard_normal(matrix.shape[0])
    lu = factorise(matrix, "pardiso")
    steps = int(lu._solver.iparm[7])
    x = lu.precondition(rhs)
    assert np.linalg.norm(matrix @ x - rhs) <= 1e-10 * np.linalg.norm(rhs)
    assert int(lu._solver.iparm[7]) == steps == sparse_lu.PARDISO_IPARM[8]
    y = factorise(matrix, "superlu").precondition(rhs)
    assert np.allclose(x, y, rtol=0.0, atol=1e-8 * np.max(np.abs(y)))
