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
#: Whether a factorisation that replaces another reuses its symbolic analysis (``PardisoLU``'s
#: ``reuse``; a benchmark turns it off to compare).
ANALYSIS_REUSE = True
#: Whether GMRES's preconditioner applies the factor without PARDISO's refinement steps
#: (``PardisoLU.precondition``; a benchmark turns it off to compare).
PRECONDITION_UNREFINED = True
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
    factorises once more with ``PARDISO_ROBUST_IPARM`` (``robust`` then True) before it refuses.

    ``reuse``: the factorisation this one replaces (a Newton step's previous LU). Its PARDISO
    handle is taken over and, when this matrix's nonzeros lie inside the sparsity pattern that
    handle analysed, only the numerical factorisation is redone (phase 22): the METIS ordering and
    symbolic analysis are about half of a factorisation (docs/dem_cost.md 33). The pattern
    analysed is the union of the patterns seen (scipy's sparse sums drop the entries that cancel,
    so consecutive Jacobians differ by a few entries); the matrix is stored on it with explicit
    zeros. ``reuse`` is spent: it must not be solved with again."""

    def __init__(self, a: sp.spmatrix, reuse: "PardisoLU | None" = None):
        a = sp.csr_matrix(a, dtype=np.float64, copy=True)
        a.sum_duplicates()
        a.eliminate_zeros()
        a.sort_indices()
        self.robust = False
        self._solver = None
        self.analysed = False  # whether this factorisation ran the symbolic analysis
        previous = reuse if isinstance(reuse, PardisoLU) and ANALYSIS_REUSE else None
        if previous is not None and previous._solver is not None and not previous.robust \
                and previous._a.shape == a.shape:
            inside = _positions(previous._keys, a)
            if inside is not None:
                self._adopt(previous)
                values = np.zeros(self._keys.size)
                values[inside] = a.data
                self._a = sp.csr_matrix((values, previous._a.indices, previous._a.indptr), shape=a.shape)
                self._call(22, np.zeros(a.shape[0]))
                return
            # a pattern outside the analysed one: analyse their union (it stops growing within a stage)
            a = _on_union(previous._a, a)
            previous._free()
        elif previous is not None:
            previous._free()
        self._set_matrix(a)
        self._factorise(PARDISO_IPARM)

    def _set_matrix(self, a: sp.csr_matrix) -> None:
        self._a = a
        self._keys = _pattern_keys(a)
        # PARDISO's 1-based index arrays, built once (pypardiso rebuilds them at every call)
        self._ia = (a.indptr + 1).astype(np.int32)
        self._ja = (a.indices + 1).astype(np.int32)

    def _adopt(self, previous: "PardisoLU") -> None:
        self._solver, previous._solver = previous._solver, None
        self._keys, self._ia, self._ja = previous._keys, previous._ia, previous._ja

    def _factorise(self, iparm: dict[int, int]) -> None:
        os.environ.setdefault("PYPARDISO_MKL_RT", _pardiso_library())
        from pypardiso import PyPardisoSolver  # the library is located above first

        self._free()
        if not np.diff(self._a.indptr).all():
            # PARDISO crashes on an empty row (pypardiso refuses it with a ValueError)
            raise SingularMatrixError("PARDISO: the matrix has an empty row")
        self._solver = PyPardisoSolver(mtype=11)  # real unsymmetric
        for key, value in iparm.items():
            self._solver.set_iparm(key, value)
        self._solver.set_iparm(12, 0)  # CSR, not transposed
        self.analysed = True
        self._call(12, np.zeros(self._a.shape[0]))

    def _call(self, phase: int, b: np.ndarray) -> np.ndarray:
        """One call of MKL's ``pardiso`` on this matrix (pypardiso's handle and iparm, our index arrays)."""
        from pypardiso.pardiso_wrapper import PyPardisoError

        s = self._solver
        b = np.asfortranarray(b, dtype=np.float64)
        x = np.zeros_like(b)
        error = ctypes.c_int32(0)
        i32 = ctypes.POINTER(ctypes.c_int32)
        f64 = ctypes.POINTER(ctypes.c_double)
        s._mkl_pardiso(s.pt.ctypes.data_as(ctypes.POINTER(s._pt_type[0])), ctypes.byref(ctypes.c_int32(1)),
                       ctypes.byref(ctypes.c_int32(1)), ctypes.byref(ctypes.c_int32(s.mtype)),
                       ctypes.byref(ctypes.c_int32(phase)), ctypes.byref(ctypes.c_int32(self._a.shape[0])),
                       self._a.data.ctypes.data_as(f64), self._ia.ctypes.data_as(i32), self._ja.ctypes.data_as(i32),
                       s.perm.ctypes.data_as(i32), ctypes.byref(ctypes.c_int32(1 if b.ndim == 1 else b.shape[1])),
                       s.iparm.ctypes.data_as(i32), ctypes.byref(ctypes.c_int32(s.msglvl)),
                       b.ctypes.data_as(f64), x.ctypes.data_as(f64), ctypes.byref(error))
        if error.value != 0:
            raise SingularMatrixError(f"PARDISO: {PyPardisoError(error.value)}")
        return np.ascontiguousarray(x)

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
        x = self._call(33, b)
        r = b - self._a @ x
        for _ in range(REFINEMENTS):
            if float(np.linalg.norm(r)) <= check * scale:
                break
            x = x + self._call(33, r)
            r = b - self._a @ x
        return x, float(np.linalg.norm(r)) / scale

    def _live(self) -> None:
        if self._solver is None:
            raise RuntimeError("this PARDISO factorisation was spent (reused by a later one)")

    def precondition(self, rhs: np.ndarray) -> np.ndarray:
        """LU^-1 rhs without PARDISO's own iterative refinement: a preconditioner's application
        (GMRES corrects what the perturbed pivots leave), at half a refined solve's cost."""
        self._live()
        steps = int(self._solver.iparm[7])
        self._solver.iparm[7] = 0
        try:
            return self._call(33, np.ascontiguousarray(rhs, dtype=np.float64))
        finally:
            self._solver.iparm[7] = steps

    def solve(self, rhs: np.ndarray, check: float | None = None) -> np.ndarray:
        """x with A x = rhs. With ``check``, the relative residual |A x - rhs| / |rhs| is brought
        under it by iterative refinement (x += LU^-1 (rhs - A x)), then by the robust factor,
        else refused (``SingularMatrixError``: a singular matrix)."""
        self._live()
        b = np.ascontiguousarray(rhs, dtype=np.float64)
        if check is None:
            return self._call(33, b)
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


def _pattern_keys(a: sp.csr_matrix) -> np.ndarray:
    """Each stored entry of ``a`` (sorted CSR) as row * n + column: ascending."""
    n = a.shape[0]
    return np.repeat(np.arange(n, dtype=np.int64), np.diff(a.indptr)) * n + a.indices


def _positions(keys: np.ndarray, a: sp.csr_matrix) -> np.ndarray | None:
    """Where ``a``'s nonzeros sit among the pattern ``keys`` (:func:`_pattern_keys`), or None if one
    lies outside it."""
    mine = _pattern_keys(a)
    at = np.searchsorted(keys, mine)
    if at.size and (at[-1] >= keys.size or not np.array_equal(keys[np.minimum(at, keys.size - 1)], mine)):
        return None
    return at


def _on_union(old: sp.csr_matrix, a: sp.csr_matrix) -> sp.csr_matrix:
    """``a`` stored on the union of its pattern and ``old``'s (explicit zeros where only ``old`` has entries)."""
    pattern = sp.csr_matrix((np.ones(old.nnz), old.indices, old.indptr), shape=old.shape)
    union = (abs(pattern) + abs(a)).tocsr()
    union.sort_indices()
    values = np.zeros(union.nnz)
    values[_positions(_pattern_keys(union), a)] = a.data
    return sp.csr_matrix((values, union.indices, union.indptr), shape=a.shape)


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

    def precondition(self, rhs: np.ndarray) -> np.ndarray:
        """LU^-1 rhs (as ``solve``)."""
        return self.solve(rhs)


def factorise(a: sp.spmatrix, backend: str | None = None, reuse: object = None) -> PardisoLU | SuperLU:
    """The LU factorisation of ``a`` by ``backend`` (``DEFAULT_BACKEND`` when None). ``reuse``: the
    factorisation this one replaces (PARDISO reuses its analysis: ``PardisoLU``); it is spent."""
    name = DEFAULT_BACKEND if backend is None else backend
    if name == "pardiso":
        return PardisoLU(a, reuse)
    if name == "superlu":
        return SuperLU(a)
    raise ValueError(f"unknown sparse LU backend {name!r} (known: {', '.join(BACKENDS)})")
