"""The coarse-graining's shared pieces: what one snapshot (or a batch of them) holds, the grid the
fields are evaluated on, the names of the per-snapshot sums, and the sparse deposit of each row's
kernel window onto the grid's bins (used by :mod:`pipeline.coarse_graining.profile` and
:mod:`pipeline.coarse_graining.plane`).

Units SI; a contact's ``branch`` is ``r1 - r2`` (minimum image across periodic faces) and its
``force`` the force on particle 1 (docs/physics.md; :mod:`pipeline.coarse_graining.coarse_grain`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

#: Raw per-snapshot sums (per unit area or length) that all fields derive from.
SUMS = ("mass", "mass_body", "volume", "mom_x", "mom_y", "mom_z", "mvv_xx", "mvv_yy", "mvv_zz", "mvv_xz",
        "dmass", "dmom_x", "c_xx", "c_yy", "c_zz", "c_xz", "c_zx")


class CoarseGrainError(ValueError):
    """Inputs the coarse-graining cannot use (empty window, bad grid, missing columns)."""


@dataclass(frozen=True)
class Grid:
    """Where fields are evaluated: z centres (m), and for x-z fields x centres (periodic, m)."""

    z: np.ndarray
    x: np.ndarray | None = None

    @property
    def dz(self) -> float:
        return float(self.z[1] - self.z[0]) if self.z.size > 1 else 1.0

    @property
    def dx(self) -> float:
        assert self.x is not None
        return float(self.x[1] - self.x[0]) if self.x.size > 1 else 1.0


@dataclass
class SnapshotData:
    """Arrays of one snapshot: particle and contact quantities (SI)."""

    pos: np.ndarray  # (N, 3) m
    vel: np.ndarray  # (N, 3) m/s
    mass: np.ndarray  # (N,) kg
    volume: np.ndarray  # (N,) m3
    body: np.ndarray  # (N,) bool: gravity acts on the grain
    r1: np.ndarray  # (M, 3) m, position of particle 1
    branch: np.ndarray  # (M, 3) m, r1 - r2 with the minimum image across periodic faces
    force: np.ndarray  # (M, 3) N, on particle 1
    box: np.ndarray  # (3, 2) m (the first snapshot's, for a batch)
    periodic: tuple[bool, bool, bool]
    # A batch of snapshots: snapshot index of every particle row and contact row, cell areas.
    psid: np.ndarray | None = None
    csid: np.ndarray | None = None
    areas: np.ndarray | None = None
    lengths: np.ndarray | None = None  # (snapshots, 3) m, box lengths of each snapshot of a batch

    @property
    def nsnap(self) -> int:
        return 1 if self.areas is None else int(self.areas.size)


def window(start: np.ndarray, span: float, origin: float, step: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid indices (N, W) whose centres may lie in [start, start + span], and a validity mask."""
    first = np.ceil((start - origin) / step).astype(np.int64)
    width = int(math.floor(span / step)) + 2
    idx = first[:, None] + np.arange(width)[None, :]
    return idx, (idx >= 0) & (idx < n)


#: Window entries (rows x window points) computed in one vectorised step. Chunks this size keep
#: the temporaries in cache and below malloc's mmap threshold: one pass over fresh large arrays
#: costs as much in page faults as in arithmetic.
CHUNK = 16_384


def chunks(rows: int | np.ndarray, width: int, chunk: int = CHUNK) -> list:
    """Row selections (slices, or index arrays when ``rows`` is an index array) of about ``chunk`` entries."""
    step = max(1, chunk // max(width, 1))
    if isinstance(rows, np.ndarray):
        return [rows[i:i + step] for i in range(0, rows.size, step)]
    return [slice(i, min(i + step, rows)) for i in range(0, rows, step)]


def deposit(flat: np.ndarray, values: np.ndarray, size: int, weights: np.ndarray) -> np.ndarray:
    """``out[k, q] = sum_{i, j: flat[i, j] = k} values[i, j] weights[i, q]``, shape (size, q).

    One sparse (bins x rows) matrix built straight from the windows (every row owns a fixed
    number of entries, so the CSC structure needs no sorting), applied to all weight columns at
    once: the particle -> grid weights are computed once and reused for every field."""
    n = values.shape[0]
    if n == 0:
        return np.zeros((size, weights.shape[1]))
    width = values.size // n
    itype = np.int32 if max(size, values.size) < 2**31 - 1 else np.int64
    matrix = sp.csc_matrix((values.reshape(-1), flat.reshape(-1).astype(itype, copy=False),
                            np.arange(0, n * width + 1, width, dtype=itype)), shape=(size, n))
    return np.asarray(matrix @ weights)


def index_type(size: int, entries: int) -> type:
    return np.int32 if max(size, entries) < 2**31 - 1 else np.int64


def particle_weights(data: SnapshotData) -> tuple[np.ndarray, np.ndarray]:
    """Per-particle weights of the kernel sums (the first ten :data:`SUMS`) and of its derivative
    (``dmass``, ``dmom_x``)."""
    m, v = data.mass, data.vel
    mvx = m * v[:, 0]
    phi_w = np.column_stack([m, m * data.body, data.volume, mvx, m * v[:, 1], m * v[:, 2],
                             mvx * v[:, 0], m * v[:, 1] ** 2, m * v[:, 2] ** 2, mvx * v[:, 2]])
    return phi_w, np.column_stack([m, mvx])


#: Index pairs (a, b) of the contact sums c_xx, c_yy, c_zz, c_xz, c_zx (f_a r_b).
CONTACT_AB = ((0, 0), (1, 1), (2, 2), (0, 2), (2, 0))
PHI_SUMS = [SUMS.index(n) for n in ("mass", "mass_body", "volume", "mom_x", "mom_y", "mom_z",
                                     "mvv_xx", "mvv_yy", "mvv_zz", "mvv_xz")]
DPHI_SUMS = [SUMS.index("dmass"), SUMS.index("dmom_x")]
CONTACT_SUMS = [SUMS.index(n) for n in ("c_xx", "c_yy", "c_zz", "c_xz", "c_zx")]


def contact_weights(data: SnapshotData, sl: slice | np.ndarray = slice(None)) -> np.ndarray:
    f, r = data.force[sl], data.branch[sl]
    return np.column_stack([f[:, a] * r[:, b] for a, b in CONTACT_AB])
