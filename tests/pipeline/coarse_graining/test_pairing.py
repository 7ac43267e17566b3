"""The contact dump is checked to be the particle dump's at every step, every contact, both grains
(pipeline.coarse_graining.pairing): what LIGGGHTS writes passes, print rounding and periodic images
included; a grain moved by a few times the rounding, at any contact of any step, is refused."""
from __future__ import annotations

import numpy as np
import pytest

from pipeline.coarse_graining.pairing import PRINT_ROUNDING, PairingError, check_contacts_match
from pipeline.dumps.reader import Dump

LX, LY, LZ = 0.016, 0.016, 0.09  # m, the default planar cell's box
GRAINS, CONTACTS, SNAPSHOTS = 300, 500, 6


def printed(values: np.ndarray) -> np.ndarray:
    """Values as LAMMPS' default ``%g`` writes and the reader reads them back (6 significant digits)."""
    return np.array([float(f"{v:g}") for v in np.ravel(values)]).reshape(np.shape(values))


def dump(kind: str, columns: tuple[str, ...], blocks: list[np.ndarray], name: str) -> Dump:
    counts = [b.shape[0] for b in blocks]
    box = np.array([[0.0, LX], [0.0, LY], [0.0, LZ]])
    return Dump(kind, columns, np.arange(1, len(blocks) + 1) * 1000, np.repeat(box[None], len(blocks), axis=0),
                ("pp", "pp", "ff"), np.concatenate([[0], np.cumsum(counts)]).astype(np.int64), np.concatenate(blocks),
                (name,))


@pytest.fixture
def pair() -> tuple[Dump, Dump]:
    """A particle and a contact dump of the same steps as LIGGGHTS writes them: grains moving
    between snapshots, ids in shuffled order, each contact's grains where the particle dump puts
    them, the second grain of a contact across a periodic face written as its image."""
    rng = np.random.default_rng(46)
    start = rng.uniform([0, 0, 0.001], [LX, LY, LZ], (GRAINS, 3))
    velocity = rng.normal(0.0, 1e-3, (GRAINS, 3))  # m per snapshot: a flowing bed
    radius = rng.uniform(0.0009, 0.0011, GRAINS)
    ids = rng.permutation(GRAINS) + 1
    grains, contacts = [], []
    for s in range(SNAPSHOTS):
        pos = start + s * velocity
        pos[:, :2] %= [LX, LY]
        grains.append(printed(np.column_stack([ids, pos, radius])))
        i, j = rng.choice(GRAINS, (2, CONTACTS))
        second = pos[j].copy()
        image = second[:, 0] - pos[i, 0] > LX / 2
        second[image, 0] -= LX  # across the periodic face: LIGGGHTS writes the ghost's position
        contacts.append(printed(np.column_stack([ids[i], ids[j], pos[i], second])))
    return (dump("atoms", ("id", "x", "y", "z", "radius"), grains, "particles.dump"),
            dump("entries", ("id1", "id2", "x1", "y1", "z1", "x2", "y2", "z2"), contacts, "contacts.dump"))


def test_a_contact_dump_written_with_its_particle_dump_passes(pair: tuple[Dump, Dump]) -> None:
    particles, contacts = pair
    check_contacts_match(particles, contacts, np.arange(SNAPSHOTS))
    # Images are there to be handled, and the rounding is the 6-digit one, not exact equality.
    assert np.any(contacts.data[:, contacts.index("x2")] < 0)


@pytest.mark.parametrize("grain", [1, 2])
def test_one_grain_of_one_contact_a_few_roundings_away_is_refused_at_its_step(pair: tuple[Dump, Dump],
                                                                              grain: int) -> None:
    particles, contacts = pair
    step = 4
    row = contacts.offsets[step] + 123
    # 4 x the largest rounding the check allows for coordinates of this size (2 x 5e-6 (|x| + |x| + L)).
    contacts.data[row, contacts.index(f"y{grain}")] += 4 * 2 * PRINT_ROUNDING * 3 * LY
    with pytest.raises(PairingError) as info:
        check_contacts_match(particles, contacts, np.arange(SNAPSHOTS))
    assert str(info.value).startswith(f"contacts.dump: at step {int(contacts.timesteps[step])} 1 of {CONTACTS} "
                                      "contacts put a grain elsewhere than the particle dump (particles.dump)")
    # Left out of the averaging window, the same step is not checked.
    check_contacts_match(particles, contacts, np.array([0, 1, 2, 3, 5]))


def test_contacts_of_the_next_snapshot_under_this_ones_steps_are_refused(pair: tuple[Dump, Dump]) -> None:
    particles, contacts = pair
    later = contacts.take(np.r_[1:SNAPSHOTS, SNAPSHOTS - 1])
    later.timesteps = contacts.timesteps.copy()
    with pytest.raises(PairingError, match=f"at step {int(contacts.timesteps[0])} {CONTACTS} of {CONTACTS} contacts"):
        check_contacts_match(particles, later, np.arange(SNAPSHOTS))


def test_a_grain_absent_from_the_particle_dump_is_named(pair: tuple[Dump, Dump]) -> None:
    particles, contacts = pair
    contacts.data[contacts.offsets[2] + 7, contacts.index("id2")] = 9001
    with pytest.raises(PairingError, match=r"contacts.dump: contacts at step 3000 name grain id\(s\) \[9001\] absent"):
        check_contacts_match(particles, contacts, np.arange(SNAPSHOTS))
