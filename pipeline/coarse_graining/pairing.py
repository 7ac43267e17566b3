"""Is a contact dump the particle dump's own? Same steps, same grains, same places.

The contact stress sums each contact's force and branch vector (from the contact dump) on the
grains' kernel weights (from the particle dump); a contact dump of another run, or of another
time of the same run (two chunks' files mixed up, snapshots relabelled), would be summed on
positions it does not belong to and give a stress that looks right. Three checks, in order:

1. a contact snapshot at the timestep of every chosen particle snapshot;
2. both grains of every contact present in the particle snapshot of that step;
3. both grains of every contact where the particle snapshot of that step puts them.

For 3, LIGGGHTS writes ``dump custom`` and ``dump local`` of one step from the same positions, so
the two agree but for the printing: LAMMPS' default ``%g`` keeps 6 significant digits, a rounding
of at most ``5e-6 |x|`` per value, and a grain of a contact that crosses a periodic face is written
as its image, ``x +- L`` with ``L`` printed to 6 digits too. A coordinate may differ by at most
``5e-6 (|x_contact| + |x_particle| + L)`` (``L`` = 0 along a fixed axis); :data:`ROUNDING_MARGIN`
times that is allowed (a dump written with fewer digits, ``dump_modify format``, is refused). On the
default run's own dumps (6 runs: rheometer, shear_gravity L4, heavy r2 and r3, two intruder;
2026-12-04) the same step's largest difference is 0.16 of this tolerance, and the LAMMPS engine's
converted contacts pass too; with the contact snapshots one snapshot late, 98-100 % of each step's
contacts have a grain beyond it (median 0.007-0.02 radii away in the beds that creep): every
contact counts, not a sample (the first rows of a dump are the bottom wall's, grains that never
move). A bed at rest gives the same positions at every step, and then the same stress: nothing to
refuse.
"""
from __future__ import annotations

import numpy as np

from pipeline.dumps.reader import Dump, DumpError

#: Relative rounding of a value printed with 6 significant digits (LAMMPS' default ``%g``).
PRINT_ROUNDING = 5e-6
#: The tolerance over that bound: room for a dump written with ``%g`` of a value computed as an
#: image (``x + L`` rounded once more in double precision) without admitting a moved grain.
ROUNDING_MARGIN = 2.0


class PairingError(DumpError):
    """A contact dump that is not of the particle dump's run or step (names both files)."""


def _files(dump: Dump) -> str:
    """The dump's files, the first and last of a run's many chunks."""
    files = dump.sources
    return ", ".join(files) if len(files) <= 3 else f"{files[0]} ... {files[-1]} ({len(files)} files)"


def contact_index(particles: Dump, contacts: Dump, chosen: np.ndarray) -> np.ndarray:
    """Indices of the contact snapshots at the timesteps of the chosen particle snapshots."""
    where = {int(t): k for k, t in enumerate(contacts.timesteps)}
    missing = [int(t) for t in particles.timesteps[chosen] if int(t) not in where]
    if missing:
        raise PairingError(f"no contact snapshot at step(s) {missing[:5]} ({_files(contacts)})")
    return np.array([where[int(t)] for t in particles.timesteps[chosen]], dtype=np.int64)


def check_contacts_match(particles: Dump, contacts: Dump, chosen: np.ndarray) -> None:
    """Refuse a contact dump that is not the particle dump's at every chosen snapshot (module
    docstring): raises :class:`PairingError` naming both files, the step and what was wrong.
    Contact dumps without grain ids (``id1``, ``id2``) are checked for their steps only."""
    chosen = np.asarray(chosen, dtype=np.int64)
    where = contact_index(particles, contacts, chosen)
    if not all(c in contacts.columns for c in ("id1", "id2")) or "id" not in particles.columns or not chosen.size:
        return
    # Snapshots in groups of about BATCH_ROWS contact rows: one vectorised pass each.
    rows = np.cumsum(contacts.counts[where])
    for group in np.split(np.arange(chosen.size), np.searchsorted(rows, np.arange(BATCH_ROWS, rows[-1], BATCH_ROWS))):
        if group.size:
            _check_group(particles, contacts, chosen[group], where[group])


#: Contact rows checked in one vectorised pass (bounds the temporaries to ~100 MB).
BATCH_ROWS = 500_000


def _stack(dump: Dump, snapshots: np.ndarray, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """The named columns of several snapshots' rows (a copy of those columns only) and the group
    position (0..) of the snapshot of each row."""
    columns = [dump.index(n) for n in names]
    if np.all(np.diff(snapshots) == 1):  # consecutive snapshots (a time window): one slice
        rows = dump.data[dump.offsets[snapshots[0]]:dump.offsets[snapshots[-1] + 1]][:, columns]
    else:
        rows = np.concatenate([dump.rows(int(s))[:, columns] for s in snapshots])
    return rows, np.repeat(np.arange(snapshots.size), dump.counts[snapshots])


def _check_group(particles: Dump, contacts: Dump, snapshots: np.ndarray, where: np.ndarray) -> None:
    """Checks 2 and 3 on particle snapshots ``snapshots`` and their contact snapshots ``where``."""
    grains, grain_snap = _stack(particles, snapshots, ("id", "x", "y", "z", "radius"))
    rows, snap = _stack(contacts, where, ("id1", "id2", "x1", "y1", "z1", "x2", "y2", "z2"))
    if rows.shape[0] == 0:
        return
    # Every grain of the group under one sorted key (snapshot, id): a contact's grain is found by one
    # binary search, whatever the ids' order and range.
    grain_ids = grains[:, 0].astype(np.int64)
    pair = rows[:, :2].astype(np.int64)
    lowest = min(int(grain_ids.min()), int(pair.min()))
    span = max(int(grain_ids.max()), int(pair.max())) - lowest + 1
    keys = grain_snap * span + (grain_ids - lowest)
    order = np.argsort(keys, kind="stable")
    keys = keys[order]
    periodic = np.nonzero([flag.startswith("p") for flag in (particles.boundary + ("pp", "pp", "ff"))[:3]])[0]
    boxes = particles.boxes[snapshots]
    lengths = np.zeros((rows.shape[0], 3))  # per contact row; 0 along a fixed axis
    lengths[:, periodic] = (boxes[:, periodic, 1] - boxes[:, periodic, 0])[snap]
    moved = np.zeros(rows.shape[0], dtype=bool)
    deltas, radii = [], []
    for k in (0, 1):
        wanted = snap * span + (pair[:, k] - lowest)
        found = np.clip(np.searchsorted(keys, wanted), 0, keys.size - 1)
        absent = keys[found] != wanted
        if absent.any():
            first = snap[np.argmax(absent)]
            missing = np.unique(pair[absent & (snap == first), k])
            raise PairingError(
                f"{_files(contacts)}: contacts at step {int(contacts.timesteps[where[first]])} name grain id(s) "
                f"{missing[:5].tolist()} absent from the particle dump ({_files(particles)}): the contact dump is "
                "not of this run")
        at = grains[order[found], 1:]  # x y z radius of the contact's grain, from the particle dump
        written = rows[:, 2 + 3 * k:5 + 3 * k]
        delta = written - at[:, :3]
        # A grain across a periodic face is written as its image.
        delta[:, periodic] -= lengths[:, periodic] * np.round(delta[:, periodic] / lengths[:, periodic])
        tolerance = ROUNDING_MARGIN * PRINT_ROUNDING * (np.abs(written) + np.abs(at[:, :3]) + lengths)
        moved |= np.any(np.abs(delta) > tolerance, axis=1)
        deltas.append(delta)
        radii.append(at[:, 3])
    if moved.any():
        first = snap[np.argmax(moved)]
        here = snap == first
        # Per contact of that step, the farther of its two grains, in its radii.
        off = np.max([np.sqrt(np.sum(d[moved & here]**2, axis=1)) / r[moved & here] for d, r in zip(deltas, radii)],
                     axis=0)
        raise PairingError(
            f"{_files(contacts)}: at step {int(contacts.timesteps[where[first]])} {off.size} of {int(here.sum())} "
            f"contacts put a grain elsewhere than the particle dump ({_files(particles)}) does at that step (median "
            f"{np.median(off):.2g}, largest {off.max():.2g} grain radii, beyond the 6-digit print rounding): the "
            "contact dump is not of this run at this step (another replica, or another time's snapshot?)")
