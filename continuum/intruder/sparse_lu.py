"""Sparse LU factorisations of the 2D Newton Jacobians (the plastic rod solvers and their
sensitivities): Intel MKL's PARDISO through ``pypardiso``, or scipy's SuperLU.

Why PARDISO: the LU factorisations are most of a plastic solve's time (61 %, docs/dem_cost.md 22;
COLAMD is SuperLU's best ordering). PARDISO orders by nested dissection (METIS) and factorises
supernodally: on six Jacobians of the default bed's volume-averaged rod (n = 6985 unknowns at 3
cells per d) a factorisation and solve takes 0.097 s against SuperLU's 0.365 s (CPU, one thread);
the pipeline's own jobs, side by side: ``benchmarks/sparse_lu.py`` (docs/dem_cost.md 26).

How it is set: one MKL thread, the sequential layer (``MKL_THREADING_SEQUENTIAL``): the default runs
two jobs on two cores, and a threaded reduction would change the last digits between runs. METIS
ordering, and PARDISO's scaling and weighted matching off (``PARDISO_IPARM``): they double the
time. Without them PARDISO perturbs the tiny pivots (the rigid zones' and the continuity rows') by
1e-13 of the matrix's norm and refines twice: relative residuals of 3e-7 or less on the six
Jacobians above. A perturbation of 1e-8 made the Newton steps of the last stages too inexact to
converge (a Cosserat rod at 2 cells per d: 196 factorisations against 43, 3.6 times the CPU). On the
two Jacobians of a mu(I) rod started from a coarser grid's state (14 d bed, eps 0.1 V/d) the
1e-13 factor leaves a residual of 7e2, and a perturbed factor never reports a singular matrix the
way SuperLU does; so a solve is checked where it matters (``check``): iterative refinement, then one
factorisation with scaling, matching and a perturbation of 1e-8 (``PARDISO_ROBUST_IPARM``: 2.4e-14
on those two, 0.21 s), then refused. The Newton steps are checked at the inexact-Newton forcing
term (GMRES's), the sensitivities at 1e-6.
"""
from __future__ import annotations

import ctypes
import glob
import os
import sys

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

#: The factorisations offered, by name (``factorise``'s ``backend``).
BACKENDS = ("pardiso", "superlu")
#: The backend every solver uses unless told otherwise (a benchmark sets it to compare).
DEFAULT_BACKEND = "pardiso"
#: PARDISO's iparm (1-based): user values (1), METIS ordering (2), two refinement steps (8),
#: pivot perturbation 1e-13 of the norm (10), no scaling (11) and no weighted matching (13).
PARDISO_IPARM = {1: 1, 2: 2, 8: 2, 10: 13, 11: 0, 13: 0}
#: The factor a checked solve falls back on: scaling and a weighted matching (PARDISO's defaults for
#: unsymmetric matrices) and a perturbation of 1e-8, twice the time of ``PARDISO_IPARM``'s.
PARDISO_ROBUST_IPARM = {**PARDISO_IPARM, 10: 8, 11: 1, 13: 1}
#: Steps of iterative refinement a checked solve may take beyond PARDISO's own.
REFINEMENTS = 4
#: MKL's ``MKL_THREADING_SEQUENTIAL``.
_MKL_SEQUENTIAL = 1


class SingularMatrixError(RuntimeError):
    """The factorisation failed, or a checked solve did not solve: a singular matrix."""


_mkl_rt: str | None = None


def _pardiso_library() -> str:
    """The path of MKL's runtime library in this Python's prefix, loaded once with the sequential
    threading layer (pypardiso then opens the same library by this path)."""
    global _mkl_rt
    if _mkl_rt is None:
        paths = sorted(glob.glob(os.path.join(sys.prefix, "lib", "libmkl_rt.so*")), key=len)
        if not paths:
            raise ImportError(f"MKL's libmkl_rt.so is not under {sys.prefix}/lib: install the mkl wheel "
                              "(a dependency of pypardiso; scripts/install.sh)")
        lib = ctypes.CDLL(paths[0])
        layer = lib.MKL_Set_Threading_Layer(ctypes.c_int(_MKL_SEQUENTIAL))
        if layer != _MKL_SEQUENTIAL:
            raise RuntimeError(f"MKL did not take the sequential threading layer (it reports {layer})")
        _mkl_rt = paths[0]
    return _mkl_rt


class PardisoLU:
    """One PARDISO factorisation of a square sparse matrix; ``solve`` as SuperLU's. It factorises
    with ``PARDISO_IPARM``; a checked solve that this factor cannot bring under its tolerance
    factorises once more with ``PARDISO_ROBUST_IPARM`` (``robust`` then True) before it refuses."""

    def __init__(self, a: sp.spmatrix):
        self._a = sp.csr_matrix(a, dtype=np.float64, copy=True)
        self._a.sort_indices()
        self.robust = False
        self._solver = None
        self._factorise(PARDISO_IPARM)

    def _factorise(self, iparm: dict[int, int]) -> None:
        os.environ.setdefault("PYPARDISO_MKL_RT", _pardiso_library())
        from pypardiso import PyPardisoSolver  # the library is located above first
        from pypardiso.pardiso_wrapper import PyPardisoError

        self._free()
        self._solver = PyPardisoSolver(mtype=11)  # real unsymmetric
        for key, value in iparm.items():
            self._solver.set_iparm(key, value)
        try:
            self._solver.factorize(self._a)
        except (PyPardisoError, ValueError) as exc:  # pypardiso refuses empty rows with a ValueError
            raise SingularMatrixError(f"PARDISO: {exc}") from exc

    def _free(self) -> None:
        """Release the factor: MKL holds it outside Python's heap, so it is not freed with the
        solver object (measured: a pytest process grew to 11 GB without this)."""
        if self._solver is not None and not sys.is_finalizing():
            self._solver.free_memory(everything=True)
        self._solver = None

    def __del__(self) -> None:
        if getattr(self, "_solver", None) is not None:
            self._free()

    def _refined(self, b: np.ndarray, check: float) -> tuple[np.ndarray, float]:
        """The solve refined up to ``REFINEMENTS`` times until its relative residual is under
        ``check``; the solution and its relative residual."""
        scale = float(np.linalg.norm(b)) or 1.0
        x = self._solver.solve(self._a, b)
        r = b - self._a @ x
        for _ in range(REFINEMENTS):
            if float(np.linalg.norm(r)) <= check * scale:
                break
            x = x + self._solver.solve(self._a, r)
            r = b - self._a @ x
        return x, float(np.linalg.norm(r)) / scale

    def solve(self, rhs: np.ndarray, check: float | None = None) -> np.ndarray:
        """x with A x = rhs. With ``check``, the relative residual |A x - rhs| / |rhs| is brought
        under it by iterative refinement (x += LU^-1 (rhs - A x)), then by the robust factor,
        else refused (``SingularMatrixError``: a singular matrix)."""
        b = np.ascontiguousarray(rhs, dtype=np.float64)
        if check is None:
            return self._solver.solve(self._a, b)
        x, relative = self._refined(b, check)
        if not relative <= check and not self.robust:
            self._factorise(PARDISO_ROBUST_IPARM)
            self.robust = True
            x, relative = self._refined(b, check)
        if not relative <= check:
            raise SingularMatrixError(f"PARDISO: the solve leaves a relative residual {relative:.2g} after "
                                      f"{REFINEMENTS} refinements of the robust factor, above {check:g} "
                                      "(a singular matrix)")
        return x


class SuperLU:
    """scipy's SuperLU (COLAMD ordering); raises ``SingularMatrixError`` on an exactly singular
    factor."""

    def __init__(self, a: sp.spmatrix):
        try:
            self._lu = splu(sp.csc_matrix(a))
        except RuntimeError as exc:
            raise SingularMatrixError(f"SuperLU: {exc}") from exc

    def solve(self, rhs: np.ndarray, check: float | None = None) -> np.ndarray:
        """x with A x = rhs (partial pivoting refuses a singular matrix when it factorises:
        ``check`` has nothing to add)."""
        return self._lu.solve(np.asarray(rhs, dtype=np.float64))


def factorise(a: sp.spmatrix, backend: str | None = None) -> PardisoLU | SuperLU:
    """The LU factorisation of ``a`` by ``backend`` (``DEFAULT_BACKEND`` when None)."""
    name = DEFAULT_BACKEND if backend is None else backend
    if name == "pardiso":
        return PardisoLU(a)
    if name == "superlu":
        return SuperLU(a)
    raise ValueError(f"unknown sparse LU backend {name!r} (known: {', '.join(BACKENDS)})")
