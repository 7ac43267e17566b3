"""Parse blocks of whitespace-separated numbers (the body of a LAMMPS text dump) into float64.

The hot loop of reading dumps is turning text into doubles. numpy's and pandas' text parsers
run at 0.2-0.6 million 16-column rows/s here, well under OVITO's reader, so a small C routine is
compiled once with the system C compiler (``cc``) into a per-user cache and called through
ctypes (which releases the GIL, so blocks parse in parallel threads). Without a compiler, or with
``GV_NO_CC=1``, the same interface falls back to pandas' C parser: slower, same results and the
same errors.

Numbers are parsed exactly as ``strtod`` would (correctly rounded): the fast path takes
mantissas of at most 19 digits scaled by an exactly representable power of ten, every other
token goes through ``strtod`` itself.
"""
from __future__ import annotations

import ctypes
import hashlib
import io
import mmap
import os
import subprocess
import tempfile
import threading
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

C_SOURCE = r"""
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>

static const double P10[23] = {1e0,1e1,1e2,1e3,1e4,1e5,1e6,1e7,1e8,1e9,1e10,1e11,1e12,1e13,
    1e14,1e15,1e16,1e17,1e18,1e19,1e20,1e21,1e22};

static inline int is_space(char c) { return c == ' ' || c == '\t' || c == '\r'; }

/* Parse one token [p, end) that is known to contain no whitespace. 0 on success. */
static int parse_token(const char *p, const char *end, double *val) {
    const char *s = p;
    int neg = 0;
    if (p < end && (*p == '-' || *p == '+')) { neg = (*p == '-'); p++; }
    /* Accumulate every digit; at most 19 digits cannot overflow 64 bits, checked afterwards. */
    uint64_t m = 0; int nd = 0, e10 = 0;
    while (p < end && (unsigned)(*p - '0') < 10u) { m = m * 10 + (uint64_t)(*p - '0'); nd++; p++; }
    if (p < end && *p == '.') {
        p++;
        const char *f = p;
        while (p < end && (unsigned)(*p - '0') < 10u) { m = m * 10 + (uint64_t)(*p - '0'); p++; }
        nd += (int)(p - f);
        e10 = -(int)(p - f);
    }
    if (nd > 0 && p < end && (*p == 'e' || *p == 'E')) {
        p++;
        int eneg = 0, ev = 0, eany = 0;
        if (p < end && (*p == '-' || *p == '+')) { eneg = (*p == '-'); p++; }
        while (p < end && (unsigned)(*p - '0') < 10u) { if (ev < 100000) ev = ev * 10 + (*p - '0'); eany = 1; p++; }
        if (!eany) return 1;
        e10 += eneg ? -ev : ev;
    }
    if (nd > 0 && nd <= 19 && p == end && m < (1ULL << 53) && e10 >= -22 && e10 <= 22) {
        /* Clinger's fast path: both operands exact, one correctly rounded operation. */
        double v = (double)m;
        v = e10 < 0 ? v / P10[-e10] : v * P10[e10];
        *val = neg ? -v : v;
        return 0;
    }
    /* Slow path: long mantissas, large exponents, nan/inf and garbage, judged by strtod. */
    char buf[128];
    size_t n = (size_t)(end - s);
    if (n >= sizeof buf || n == 0) return 1;
    memcpy(buf, s, n); buf[n] = 0;
    /* strtod also reads C99 hex floats ("0x.0", "0x1p3") and "nan(...)": no dump writes them and
       Python's float() refuses them, so a token holding them is corruption, not a number. */
    if (strpbrk(buf, "xX(")) return 1;
    char *stop;
    double v = strtod(buf, &stop);
    if (stop != buf + n) return 1;
    *val = v;
    return 0;
}

/* Parse nrows lines of exactly ncols tokens. Return 0 on success, else an error code:
   1 bad number, 2 non-finite number, 3 too few columns, 4 too many columns, 5 too few lines.
   err_row / err_col say where (0-based); consumed is the length of the parsed lines. */
int parse_block(const char *buf, int64_t len, int64_t nrows, int64_t ncols, double *out,
                int64_t *err_row, int64_t *err_col, int64_t *consumed) {
    const char *p = buf, *end = buf + len;
    for (int64_t r = 0; r < nrows; r++) {
        for (int64_t c = 0; c < ncols; c++) {
            while (p < end && is_space(*p)) p++;
            if (p >= end) { *err_row = r; *err_col = c; return (c == 0) ? 5 : 3; }
            if (*p == '\n') { *err_row = r; *err_col = c; return 3; }
            const char *t = p;
            while (p < end && !is_space(*p) && *p != '\n') p++;
            double v;
            if (parse_token(t, p, &v)) { *err_row = r; *err_col = c; return 1; }
            /* nan and inf are kept: whether they matter depends on the column (reader.py checks the
               columns the coarse-graining reads). */
            out[r * ncols + c] = v;
        }
        while (p < end && is_space(*p)) p++;
        if (p < end && *p != '\n') { *err_row = r; *err_col = ncols; return 4; }
        if (p < end) p++;
    }
    *consumed = (int64_t)(p - buf);
    return 0;
}
"""

ERROR_TEXT = {
    1: "not a number",
    2: "non-finite value (nan or inf)",
    3: "too few columns",
    4: "too many columns",
    5: "file ends before the expected number of lines",
}


@dataclass(frozen=True)
class BlockError(Exception):
    """A parse failure at a 0-based row and column of a block; ``code`` indexes ERROR_TEXT."""

    code: int
    row: int
    column: int

    def __str__(self) -> str:
        return f"{ERROR_TEXT.get(self.code, 'parse error')} (row {self.row}, column {self.column + 1})"


_lock = threading.Lock()
_lib: ctypes.CDLL | None = None
_tried = False


def _cache_dir() -> Path:
    root = os.environ.get("GV_CACHE_DIR") or os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(root) / "granular-validate"


def _compile() -> ctypes.CDLL | None:
    """Build (once per source version) and load the C parser; None when no compiler works."""
    if os.environ.get("GV_NO_CC"):
        return None
    tag = hashlib.sha256(C_SOURCE.encode()).hexdigest()[:16]
    target = _cache_dir() / f"fastparse-{tag}.so"
    try:
        if not target.exists():
            target.parent.mkdir(parents=True, exist_ok=True)
            with tempfile.TemporaryDirectory(dir=target.parent) as tmp:
                src = Path(tmp) / "fastparse.c"
                src.write_text(C_SOURCE)
                out = Path(tmp) / "fastparse.so"
                cc = os.environ.get("CC", "cc")
                subprocess.run([cc, "-O3", "-shared", "-fPIC", "-o", str(out), str(src)],
                               check=True, capture_output=True, timeout=120)
                # Rename into place: concurrent workflow jobs never load a half-written library.
                os.replace(out, target)
        lib = ctypes.CDLL(str(target))
    except (OSError, subprocess.SubprocessError):
        return None
    lib.parse_block.restype = ctypes.c_int
    lib.parse_block.argtypes = [ctypes.c_void_p, ctypes.c_int64, ctypes.c_int64, ctypes.c_int64,
                                ctypes.c_void_p, ctypes.POINTER(ctypes.c_int64), ctypes.POINTER(ctypes.c_int64),
                                ctypes.POINTER(ctypes.c_int64)]
    return lib


def compiled() -> bool:
    """True when the compiled parser is in use (False: the pandas fallback)."""
    global _lib, _tried
    with _lock:
        if not _tried:
            _lib, _tried = _compile(), True
            if _lib is None and not os.environ.get("GV_NO_CC"):
                # Not silent: the results are the same, but reading is about 3x slower.
                warnings.warn("no working C compiler: dump parsing falls back to pandas (same results, "
                              "about 3x slower); install gcc (scripts/install.sh does)", RuntimeWarning, stacklevel=2)
    return _lib is not None


def parse_block(buf: bytes | mmap.mmap, start: int, stop: int, nrows: int, ncols: int,
                out: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Parse ``nrows`` lines of ``ncols`` numbers from ``buf[start:stop]`` into (nrows, ncols) float64.

    ``out``, if given, is a C-contiguous float64 (nrows, ncols) array filled in place. Returns the
    array and the offset in ``buf`` just after the last parsed line (the caller checks what
    follows). Raises :class:`BlockError` for a malformed, short or non-finite block.
    """
    if out is None:
        out = np.empty((nrows, ncols), dtype=np.float64)
    elif out.shape != (nrows, ncols) or out.dtype != np.float64 or not out.flags.c_contiguous:
        raise ValueError("out must be a C-contiguous float64 array of shape (nrows, ncols)")
    if nrows == 0:
        return out, start
    if not 0 <= start <= stop <= len(buf):
        raise ValueError("block outside the buffer")
    if compiled():
        assert _lib is not None
        row, col, used = ctypes.c_int64(-1), ctypes.c_int64(-1), ctypes.c_int64(0)
        # Point into the buffer (bytes or a read-only mmap) without copying it.
        base = np.frombuffer(buf, dtype=np.uint8).ctypes.data
        code = _lib.parse_block(base + start, stop - start, nrows, ncols, out.ctypes.data,
                                ctypes.byref(row), ctypes.byref(col), ctypes.byref(used))
        if code:
            raise BlockError(code, int(row.value), int(col.value))
        return out, start + int(used.value)
    parsed, end = _parse_block_pandas(buf, start, stop, nrows, ncols)
    out[...] = parsed
    return out, end


def _parse_block_pandas(buf: bytes | mmap.mmap, start: int, stop: int, nrows: int, ncols: int) -> tuple[np.ndarray, int]:
    """The fallback: pandas' C parser, then the same checks as the compiled parser."""
    import pandas as pd

    pieces = buf[start:stop].split(b"\n", nrows)
    body = pieces[:nrows]
    if len(body) < nrows or not body[-1].strip():
        filled = [r for r, line in enumerate(body) if not line.strip()]
        raise BlockError(5, filled[0] if filled else len(body), 0)
    for r, line in enumerate(body):
        n = len(line.split())
        if n != ncols:
            raise BlockError(3 if n < ncols else 4, r, min(n, ncols))
    try:
        frame = pd.read_csv(io.BytesIO(b"\n".join(body)), sep=r"\s+", header=None, dtype=np.float64,
                            engine="c", na_filter=False)
    except ValueError:
        # A token pandas' C parser will not take: a bad number (named), or nan / inf (kept).
        rows = []
        for r, line in enumerate(body):
            values = []
            for c, word in enumerate(line.split()):
                try:
                    values.append(float(word))
                except ValueError:
                    raise BlockError(1, r, c) from None
            rows.append(values)
        frame = pd.DataFrame(rows, dtype=np.float64)
    out = frame.to_numpy(dtype=np.float64)
    consumed = sum(len(line) + 1 for line in body)
    return out, min(start + consumed, stop)
