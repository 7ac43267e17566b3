"""Fast readers of LAMMPS/LIGGGHTS text dumps: ``dump custom`` particle files, ``dump local`` contacts.

A dump file is a sequence of snapshots, each::

    ITEM: TIMESTEP / <step> / ITEM: NUMBER OF ATOMS|ENTRIES / <n> /
    ITEM: BOX BOUNDS <bx> <by> <bz> / 3 lines "lo hi" / ITEM: ATOMS|ENTRIES <names...> / n lines

Columns are found by their header names, never by position. Particle files need positions,
velocities, radius (or diameter) and mass; contact files need both positions, the force on
particle 1 and the periodic flag. ``dump local`` cannot name its columns in LIGGGHTS, so generic
``c_ID[k]`` names are mapped to physical names by a list (default :data:`CONTACT_COLUMNS`, the
order of ``compute pair/gran/local pos id force contactPoint delta``, also stored in run.json
``contact_columns``); files whose headers already carry physical names are read as they are.

Anything else fails with :class:`DumpError` naming the file and the line.
"""
from __future__ import annotations

import gzip
import mmap
import os
import re
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from pipeline.dumps import fastparse

#: Physical names of the 16 pair/gran/local outputs ``pos id force contactPoint delta`` as LIGGGHTS
#: orders them (pos 6, id 3, force 3, delta 1, contactPoint 3). ``f*`` is the force on particle 1.
CONTACT_COLUMNS: tuple[str, ...] = (
    "x1", "y1", "z1", "x2", "y2", "z2", "id1", "id2", "periodic",
    "fx", "fy", "fz", "delta", "cx", "cy", "cz",
)
#: Columns the coarse-graining needs from a particle dump (after synonyms are resolved).
PARTICLE_REQUIRED: tuple[str, ...] = ("x", "y", "z", "vx", "vy", "vz", "radius", "mass")
#: Columns the coarse-graining needs from a contact dump.
CONTACT_REQUIRED: tuple[str, ...] = ("x1", "y1", "z1", "x2", "y2", "z2", "fx", "fy", "fz")

#: Other spellings accepted for the physical contact names (LAMMPS-style and common aliases).
CONTACT_SYNONYMS: dict[str, str] = {
    "pos1x": "x1", "pos1y": "y1", "pos1z": "z1", "pos2x": "x2", "pos2y": "y2", "pos2z": "z2",
    "xi": "x1", "yi": "y1", "zi": "z1", "xj": "x2", "yj": "y2", "zj": "z2",
    "x_i": "x1", "y_i": "y1", "z_i": "z1", "x_j": "x2", "y_j": "y2", "z_j": "z2",
    "patom1": "id1", "patom2": "id2", "idi": "id1", "idj": "id2", "id_i": "id1", "id_j": "id2",
    "f_x": "fx", "f_y": "fy", "f_z": "fz", "forcex": "fx", "forcey": "fy", "forcez": "fz",
    "fix": "fx", "fiy": "fy", "fiz": "fz",
    "contactpointx": "cx", "contactpointy": "cy", "contactpointz": "cz",
    "overlap": "delta",
}
_NONBLANK = re.compile(rb"\S")
_GENERIC = re.compile(r"^[cfv]_[A-Za-z0-9_]+\[(\d+)\]$")


GZIP_MAGIC = b"\x1f\x8b"
#: Lines of a snapshot's header in a LAMMPS text dump (timestep, count, box bounds, column names).
SNAPSHOT_HEADER_LINES = 9


class DumpError(ValueError):
    """A dump file is missing, truncated, malformed or lacks a needed column."""


@dataclass
class Dump:
    """All snapshots of one or more dump files, rows concatenated.

    ``data[offsets[s]:offsets[s+1]]`` are the rows of snapshot ``s``; ``boxes[s]`` is the box
    ``[[xlo, xhi], [ylo, yhi], [zlo, zhi]]`` (m); ``boundary`` the LAMMPS boundary flags.
    """

    kind: str  # "atoms" (dump custom) or "entries" (dump local)
    columns: tuple[str, ...]
    timesteps: np.ndarray
    boxes: np.ndarray
    boundary: tuple[str, ...]
    offsets: np.ndarray
    data: np.ndarray
    sources: tuple[str, ...] = field(default_factory=tuple)

    def __len__(self) -> int:
        return int(self.timesteps.size)

    @property
    def counts(self) -> np.ndarray:
        """Rows per snapshot."""
        return np.diff(self.offsets)

    def index(self, name: str) -> int:
        try:
            return self.columns.index(name)
        except ValueError:
            raise DumpError(f"{', '.join(self.sources)}: no column {name!r} (columns: {' '.join(self.columns)})") from None

    def column(self, name: str) -> np.ndarray:
        """All rows of one column (a strided view)."""
        return self.data[:, self.index(name)]

    def rows(self, s: int) -> np.ndarray:
        """The rows of snapshot ``s``."""
        return self.data[self.offsets[s]:self.offsets[s + 1]]

    def take(self, snapshots: np.ndarray) -> Dump:
        """A new Dump with the given snapshot indices, in that order."""
        snapshots = np.asarray(snapshots, dtype=np.int64)
        counts = self.counts[snapshots]
        offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        rows = np.concatenate([np.arange(self.offsets[s], self.offsets[s + 1]) for s in snapshots]) if snapshots.size else np.zeros(0, np.int64)
        return Dump(self.kind, self.columns, self.timesteps[snapshots], self.boxes[snapshots], self.boundary,
                    offsets, self.data[rows], self.sources)


def shift_periodic_x(dump: Dump, snapshots: np.ndarray, shifts: np.ndarray, columns: Sequence[str]) -> Dump:
    """The given snapshots of ``dump``, with the named x columns moved by each snapshot's shift (m)
    and wrapped back into the periodic box."""
    part = dump.take(snapshots)
    data = part.data.copy()
    per_row = np.repeat(np.asarray(shifts, dtype=float), part.counts)
    lo = np.repeat(part.boxes[:, 0, 0], part.counts)
    length = np.repeat(part.boxes[:, 0, 1] - part.boxes[:, 0, 0], part.counts)
    for name in columns:
        i = part.index(name)
        data[:, i] = lo + np.mod(data[:, i] + per_row - lo, length)
    return replace(part, data=data)


@dataclass
class _Block:
    timestep: int
    n: int
    box: np.ndarray
    start: int  # byte offset of the first data line
    stop: int  # byte offset of the next ITEM: (or end of file)
    line: int  # 1-based line number of the first data line


class _Lines:
    """Header-line cursor over the raw bytes, tracking line numbers for messages."""

    def __init__(self, raw: bytes | mmap.mmap, path: Path) -> None:
        self.raw, self.path, self.pos, self.line = raw, path, 0, 1

    def fail(self, message: str, line: int | None = None) -> DumpError:
        return DumpError(f"{self.path}:{self.line if line is None else line}: {message}")

    def next(self, what: str) -> str:
        if self.pos >= len(self.raw):
            raise self.fail(f"file ends where {what} was expected (truncated?)")
        end = self.raw.find(b"\n", self.pos)
        end = len(self.raw) if end < 0 else end
        text = self.raw[self.pos:end].decode("ascii", errors="replace").strip()
        # Never past the end: a last line without its newline must leave the data blocks inside the file.
        self.pos, self.line = min(end + 1, len(self.raw)), self.line + 1
        return text

    def expect(self, prefix: str) -> str:
        text = self.next(f"'{prefix}'")
        if not text.startswith(prefix):
            self.line -= 1
            raise self.fail(f"expected '{prefix}', found {text[:60]!r}")
        return text[len(prefix):].strip()

    def number(self, what: str, kind: type) -> float | int:
        text = self.next(what)
        try:
            value = kind(text.split()[0]) if kind is float else int(text)
        except (ValueError, IndexError):
            self.line -= 1
            raise self.fail(f"expected {what}, found {text[:60]!r}") from None
        return value


def _scan(raw: bytes | mmap.mmap, path: Path) -> tuple[str, tuple[str, ...], tuple[str, ...], list[_Block]]:
    """Read every header; return kind, column names, boundary flags and the data blocks."""
    cur = _Lines(raw, path)
    kind = ""
    names: tuple[str, ...] = ()
    boundary: tuple[str, ...] = ()
    blocks: list[_Block] = []
    while _NONBLANK.search(raw, cur.pos):
        cur.expect("ITEM: TIMESTEP")
        step = int(cur.number("a timestep", int))
        count_line = cur.expect("ITEM: NUMBER OF")
        this_kind = {"ATOMS": "atoms", "ENTRIES": "entries"}.get(count_line)
        if this_kind is None:
            cur.line -= 1
            raise cur.fail(f"unknown 'ITEM: NUMBER OF {count_line}' (expected ATOMS or ENTRIES)")
        n = int(cur.number("a row count", int))
        if n < 0:
            raise cur.fail(f"negative row count {n}", cur.line - 1)
        bounds = cur.expect("ITEM: BOX BOUNDS").split()
        if len(bounds) > 3:
            raise cur.fail("triclinic box (tilt factors) is not supported", cur.line - 1)
        box = np.empty((3, 2))
        for axis in range(3):
            text = cur.next("a box bound line")
            try:
                box[axis] = [float(w) for w in text.split()[:2]]
                if len(text.split()) != 2:
                    raise ValueError
            except ValueError:
                raise cur.fail(f"expected 'lo hi' box bounds, found {text[:60]!r}", cur.line - 1) from None
        if blocks and step <= blocks[-1].timestep:
            # A restarted run that appended to its dump repeats steps: which copy is right is unknown.
            raise cur.fail(f"step {step} follows step {blocks[-1].timestep}: timesteps must increase within a "
                           "file (a restarted run appended to it?)", cur.line - 5)
        header = cur.expect(f"ITEM: {'ATOMS' if this_kind == 'atoms' else 'ENTRIES'}").split()
        if not header:
            raise cur.fail("no column names in the header", cur.line - 1)
        if not blocks:
            kind, names, boundary = this_kind, tuple(header), tuple(bounds)
        elif this_kind != kind or tuple(header) != names:
            raise cur.fail("columns differ from the first snapshot of the file", cur.line - 1)
        stop = raw.find(b"ITEM:", cur.pos)
        stop = len(raw) if stop < 0 else stop
        blocks.append(_Block(step, n, box, cur.pos, stop, cur.line))
        cur.pos, cur.line = stop, cur.line + n
    if not blocks:
        raise DumpError(f"{path}:1: no snapshot in the file")
    return kind, names, boundary, blocks


def default_threads() -> int:
    """Parser threads: the cores this process may use, at most 4."""
    try:
        return max(1, min(4, len(os.sched_getaffinity(0))))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, min(4, os.cpu_count() or 1))


def read_dump(path: str | Path, threads: int | None = None) -> Dump:
    """Read every snapshot of one text dump, column names as in the file header."""
    path = Path(path)
    if not path.is_file():
        raise DumpError(f"{path}: dump file not found")
    if path.stat().st_size == 0:
        raise DumpError(f"{path}:1: empty file")
    with open(path, "rb") as handle:
        gzipped = handle.read(2) == GZIP_MAGIC
    if gzipped:
        # gzip (as LAMMPS writes with dump ... .gz, or users compress): decompressed in memory,
        # whatever the file's name; line numbers in messages are those of the decompressed text.
        try:
            with gzip.open(path, "rb") as handle:
                raw_bytes = handle.read()
        except (OSError, EOFError) as exc:
            raise DumpError(f"{path}: not a readable gzip file ({exc})") from None
        if not raw_bytes:
            raise DumpError(f"{path}:1: empty file (after decompression)")
        return _read_mapped(raw_bytes, path, threads)
    # A read-only map: pages are read as the parser threads reach them, overlapping I/O and parsing.
    with open(path, "rb") as handle:
        raw = mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ)
    try:
        return _read_mapped(raw, path, threads)
    finally:
        raw.close()


def _read_mapped(raw: mmap.mmap | bytes, path: Path, threads: int | None) -> Dump:
    kind, names, boundary, blocks = _scan(raw, path)
    ncols = len(names)
    counts = np.array([b.n for b in blocks], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    data = np.empty((int(offsets[-1]), ncols), dtype=np.float64)

    def parse(i: int) -> None:
        block = blocks[i]
        try:
            _, end = fastparse.parse_block(raw, block.start, block.stop, block.n, ncols,
                                           out=data[offsets[i]:offsets[i + 1]])
        except fastparse.BlockError as err:
            line = block.line + err.row
            if err.code == 5:
                raise DumpError(f"{path}:{line}: snapshot at step {block.timestep} ends after {err.row} of "
                                f"{block.n} lines (truncated file?)") from None
            raise DumpError(f"{path}:{line}: {err}") from None
        if raw[end:block.stop].strip():
            raise DumpError(f"{path}:{block.line + block.n}: more lines than the {block.n} announced "
                            f"for step {block.timestep}")

    workers = threads or default_threads()
    if workers > 1 and len(blocks) > 1:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            list(pool.map(parse, range(len(blocks))))
    else:
        for i in range(len(blocks)):
            parse(i)
    # LIGGGHTS ends every line with a newline. A last line without one was cut while being written:
    # a cut inside its last number would otherwise parse as a different, valid number.
    if raw[len(raw) - 1:] != b"\n":
        last_line = raw[:].count(b"\n") + 1
        raise DumpError(f"{path}:{last_line}: the file ends inside a line (truncated?)")
    return Dump(kind, names, np.array([b.timestep for b in blocks], dtype=np.int64),
                np.stack([b.box for b in blocks]), boundary, offsets, data, (str(path),))


def concat(dumps: Sequence[Dump]) -> Dump:
    """Join dumps in time, dropping repeated timesteps (consecutive chunks both dump their boundary)."""
    if not dumps:
        raise DumpError("no dump files given")
    first = dumps[0]
    for other in dumps[1:]:
        if other.columns != first.columns or other.kind != first.kind:
            raise DumpError(f"{other.sources[0]}: columns differ from {first.sources[0]}")
    steps = np.concatenate([d.timesteps for d in dumps])
    _, keep = np.unique(steps, return_index=True)  # first occurrence of each step, in step order
    offsets = [0]
    for d in dumps:
        offsets.append(offsets[-1] + d.data.shape[0])
    joined = Dump(first.kind, first.columns, steps, np.concatenate([d.boxes for d in dumps]), first.boundary,
                  np.concatenate([[0]] + [d.offsets[1:] + o for d, o in zip(dumps, offsets[:-1])]).astype(np.int64),
                  np.concatenate([d.data for d in dumps]) if len(dumps) > 1 else first.data,
                  tuple(s for d in dumps for s in d.sources))
    if keep.size == steps.size and np.all(np.diff(steps) > 0):
        return joined
    return joined.take(keep)


def _rename(dump: Dump, names: tuple[str, ...]) -> Dump:
    if len(set(names)) != len(names):
        raise DumpError(f"{dump.sources[0]}: repeated column names {' '.join(names)}")
    return Dump(dump.kind, names, dump.timesteps, dump.boxes, dump.boundary, dump.offsets, dump.data, dump.sources)


def check_finite(dump: Dump, columns: Sequence[str]) -> None:
    """Refuse a nan or inf in a column the coarse-graining reads, naming the file, the step, the
    row of the snapshot and the column; other columns may hold anything (an extra per-atom column
    nothing here computes from is no reason to refuse a dump)."""
    present = [c for c in columns if c in dump.columns]
    if not present or dump.data.size == 0:
        return
    idx = [dump.columns.index(c) for c in present]
    bad = ~np.isfinite(dump.data[:, idx])
    if not bad.any():
        return
    row, col = (int(v) for v in np.argwhere(bad)[0])
    snapshot = int(np.searchsorted(dump.offsets, row, side="right") - 1)
    value = f"non-finite value {dump.data[row, idx[col]]} in column {present[col]}, which the coarse-graining reads"
    if len(dump.sources) == 1:
        # One file: each snapshot is 9 header lines and its rows, so the line is known.
        line = SNAPSHOT_HEADER_LINES * (snapshot + 1) + row + 1
        raise DumpError(f"{dump.sources[0]}:{line}: {value}")
    raise DumpError(f"{', '.join(dump.sources)}: step {int(dump.timesteps[snapshot])}, row "
                    f"{row - int(dump.offsets[snapshot]) + 1} of the snapshot: {value}")


def check_not_empty(dump: Dump, what: str) -> None:
    """Refuse a dump whose snapshots hold no rows (no grains, or no contacts), naming the files."""
    if dump.data.shape[0] == 0:
        raise DumpError(f"{', '.join(dump.sources)}: {len(dump)} snapshot(s) and not one {what} in any: nothing to "
                        "coarse-grain")


def _require(dump: Dump, required: Sequence[str], hint: str) -> None:
    missing = [c for c in required if c not in dump.columns]
    if missing:
        raise DumpError(f"{dump.sources[0]}:{_header_line(dump)}: missing column(s) {' '.join(missing)} "
                        f"(header: {' '.join(dump.columns)}); {hint}")


def _header_line(dump: Dump) -> int:
    return 9  # the column header of the first snapshot is always line 9


def particle_view(dump: Dump, rho_s: float | None = None, diameter: float | None = None) -> Dump:
    """Resolve particle-column spellings: ``xu``/``xs`` to ``x``, ``diameter`` to ``radius``.

    A dump without ``radius`` (or ``diameter``) takes the single grain diameter ``diameter`` (m)
    when given; a dump without ``mass`` takes ``rho_s * pi d^3 / 6`` from each grain's size when
    the grain density ``rho_s`` (kg m-3) is given. Neither is ever assumed: without them such a
    dump is refused, naming the option that supplies the column.
    """
    if dump.kind != "atoms":
        raise DumpError(f"{dump.sources[0]}:3: not a particle dump ('ITEM: NUMBER OF ATOMS' expected)")
    names = list(dump.columns)
    data = dump.data
    for axis, a in enumerate("xyz"):
        if a in names:
            continue
        if f"{a}u" in names:
            names[names.index(f"{a}u")] = a
        elif f"{a}s" in names:
            # Scaled coordinates: x = lo + xs (hi - lo), per snapshot.
            j = names.index(f"{a}s")
            data = data.copy() if data is dump.data else data
            lo = np.repeat(dump.boxes[:, axis, 0], dump.counts)
            hi = np.repeat(dump.boxes[:, axis, 1], dump.counts)
            data[:, j] = lo + data[:, j] * (hi - lo)
            names[j] = a
    if "radius" not in names and "diameter" in names:
        j = names.index("diameter")
        data = data.copy() if data is dump.data else data
        data[:, j] *= 0.5
        names[j] = "radius"
    columns = list(dump.columns)
    if "radius" not in names and diameter is not None:
        data = np.column_stack([data, np.full(data.shape[0], 0.5 * diameter)])
        names.append("radius")
        columns.append("radius")
    if "mass" not in names and rho_s is not None and "radius" in names:
        radius = data[:, names.index("radius")]
        data = np.column_stack([data, rho_s * 4.0 / 3.0 * np.pi * radius**3])
        names.append("mass")
        columns.append("mass")
    out = _rename(Dump(dump.kind, tuple(columns), dump.timesteps, dump.boxes, dump.boundary, dump.offsets, data,
                       dump.sources), tuple(names))
    _require(out, PARTICLE_REQUIRED, "a particle dump needs x y z vx vy vz radius mass (without mass: give "
             "the grain density, --rho-s; without radius or diameter: the grain diameter, --diameter)")
    check_not_empty(out, "grain")
    check_finite(out, (*PARTICLE_REQUIRED, "id", "type"))
    return out


def check_particle_rows(dump: Dump, snapshots: Sequence[int] | None = None) -> None:
    """Refuse what would corrupt fields without an error of its own: a box of no extent, a repeated
    grain id in one snapshot (the row would be averaged in twice), a grain outside the box (the
    fields would be stretched or lose mass). ``snapshots``: the ones to check (default all)."""
    source = ", ".join(dump.sources)
    cols = [dump.index(a) for a in "xyz"]
    ids = dump.columns.index("id") if "id" in dump.columns else None
    for s in range(len(dump)) if snapshots is None else snapshots:
        rows = dump.rows(s)
        for axis in range(3):
            lo, hi = dump.boxes[s, axis]
            if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
                raise DumpError(f"{source}: step {int(dump.timesteps[s])}: box bounds {lo:g} {hi:g}: the box has no "
                                f"extent along {'xyz'[axis]}")
        if ids is not None:
            unique, counts = np.unique(rows[:, ids], return_counts=True)
            if np.any(counts > 1):
                raise DumpError(f"{source}: step {int(dump.timesteps[s])}: grain id {int(unique[counts > 1][0])} "
                                "appears twice in one snapshot")
        for axis in range(3):
            lo, hi = dump.boxes[s, axis]
            value = rows[:, cols[axis]]
            # LAMMPS wraps periodic coordinates into the box only when it reneighbours, and a fixed
            # boundary's box may lag the grains by as much: a grain may sit up to a skin distance
            # outside; more than a tenth of the box is not that.
            slack = 0.1 * (hi - lo)
            if value.size and (value.min() < lo - slack or value.max() > hi + slack):
                raise DumpError(f"{source}: step {int(dump.timesteps[s])}: a grain at {'xyz'[axis]} = "
                                f"{value.min() if value.min() < lo - slack else value.max():.6g} lies outside the "
                                f"box [{lo:.6g}, {hi:.6g}]")


def contact_view(dump: Dump, names: Sequence[str] | Mapping[str, str] | None = None) -> Dump:
    """Give the columns of a contact dump their physical names.

    ``names``: the physical name of the k-th generic column ``c_ID[k]`` (a sequence, default
    :data:`CONTACT_COLUMNS`) or an explicit {header name: physical name} mapping. Headers that
    are already physical (``x1 ... fx ...`` or a synonym in :data:`CONTACT_SYNONYMS`) need none.
    """
    if dump.kind != "entries":
        raise DumpError(f"{dump.sources[0]}:3: not a contact dump ('ITEM: NUMBER OF ENTRIES' expected)")
    out: list[str] = []
    for header in dump.columns:
        if isinstance(names, Mapping) and header in names:
            out.append(names[header])
            continue
        match = _GENERIC.match(header)
        if match:
            table = CONTACT_COLUMNS if names is None or isinstance(names, Mapping) else tuple(names)
            k = int(match.group(1))
            if not 1 <= k <= len(table):
                raise DumpError(f"{dump.sources[0]}:9: column {header} has no physical name "
                                f"(mapping has {len(table)} names)")
            out.append(table[k - 1])
        else:
            out.append(CONTACT_SYNONYMS.get(header.lower(), header.lower() if header.lower() in CONTACT_COLUMNS else header))
    view = _rename(dump, tuple(out))
    _require(view, CONTACT_REQUIRED, "pass the column mapping of generic c_ID[k] names (contact_columns)")
    check_finite(view, (*CONTACT_REQUIRED, "id1", "id2", "periodic", "delta", "cx", "cy", "cz"))
    return view


def read_particles(paths: Sequence[str | Path] | str | Path, threads: int | None = None,
                   rho_s: float | None = None, diameter: float | None = None) -> Dump:
    """Read particle dumps (one or several chunks or per-snapshot files, plain or gzip, duplicate
    boundary steps dropped); ``rho_s`` and ``diameter`` supply a missing mass or size column
    (:func:`particle_view`)."""
    paths = [paths] if isinstance(paths, (str, Path)) else list(paths)
    return particle_view(concat([read_dump(p, threads) for p in paths]), rho_s=rho_s, diameter=diameter)


def read_contacts(paths: Sequence[str | Path] | str | Path,
                  names: Sequence[str] | Mapping[str, str] | None = None, threads: int | None = None) -> Dump:
    """Read contact dumps with physical column names (see :func:`contact_view`)."""
    paths = [paths] if isinstance(paths, (str, Path)) else list(paths)
    return contact_view(concat([read_dump(p, threads) for p in paths]), names)
