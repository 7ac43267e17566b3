"""The dump readers: columns by header name, multi-snapshot, chunks joined, loud on bad input."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from pipeline.dumps import reader as dumps
from pipeline.dumps import fastparse

PARTICLE_HEADER = "id type x y z vx vy vz omegax omegay omegaz radius mass fx fy fz"


def write_snapshots(path: Path, header: str, kind: str, snapshots: list[tuple[int, np.ndarray]],
                    fmt: str = "%.17g", mode: str = "w") -> None:
    """A text dump as LAMMPS writes it (trailing space after the column names, like LIGGGHTS)."""
    with open(path, mode) as f:
        for step, rows in snapshots:
            f.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF {kind}\n{len(rows)}\nITEM: BOX BOUNDS pp pp ff\n"
                    f"0 0.01\n0 0.02\n-0.001 0.05\nITEM: {kind} {header} \n")
            for row in rows:
                f.write(" ".join(fmt % v for v in row) + "\n")


@pytest.fixture(params=["compiled", "pandas"])
def parser(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run a test with the compiled parser and with the pandas fallback."""
    if request.param == "compiled":
        # scripts/install.sh installs a C compiler, so the fast parser must be there.
        assert fastparse.compiled(), "no C compiler: the compiled dump parser is not available"
    else:
        monkeypatch.setattr(fastparse, "_lib", None)
        monkeypatch.setattr(fastparse, "_tried", True)
    return request.param


def particle_rows(rng: np.random.Generator, n: int) -> np.ndarray:
    rows = rng.normal(size=(n, 16))
    rows[:, 0] = np.arange(1, n + 1)
    rows[:, 1] = rng.integers(1, 4, n)
    rows[:, 11] = 0.001 + 0.0002 * rng.random(n)
    rows[:, 12] = 1e-5 * (1 + rng.random(n))
    return rows


def test_columns_are_found_by_name_whatever_their_order(tmp_path, rng, parser):
    names = PARTICLE_HEADER.split()
    rows = particle_rows(rng, 50)
    order = rng.permutation(len(names))
    write_snapshots(tmp_path / "p.dump", " ".join(names[k] for k in order), "ATOMS",
                    [(100, rows[:, order]), (200, rows[:, order] * 2)])
    dump = dumps.read_particles(tmp_path / "p.dump", threads=2)
    assert list(dump.timesteps) == [100, 200]
    assert list(dump.counts) == [50, 50]
    for k, name in enumerate(names):
        # %.17g round-trips doubles: the parse must be exact, not merely close.
        np.testing.assert_array_equal(dump.rows(0)[:, dump.index(name)], rows[:, k])
        np.testing.assert_array_equal(dump.rows(1)[:, dump.index(name)], 2 * rows[:, k])
    assert dump.boundary == ("pp", "pp", "ff")
    np.testing.assert_array_equal(dump.boxes[0], [[0, 0.01], [0, 0.02], [-0.001, 0.05]])


def test_numbers_parse_exactly_like_python_float(tmp_path, rng, parser):
    values = np.concatenate([rng.normal(size=300) * 10.0 ** rng.integers(-30, 30, 300),
                             [0.0, -0.0, 5e-324, 1.7976931348623157e308, 1e22, 1e23, 123456789012345678901.0]])
    texts = []
    for k, v in enumerate(values):
        texts.append(["%.17g", "%g", "%.6e", "%.12E", "%r"][k % 5] % v if k % 5 != 4 else repr(float(v)))
    texts += ["+1.5", "7", "-0", "1e5", "0.000000000000000000000000123456", "1234567890123456789012345"]
    n = len(texts) // 4 * 4
    path = tmp_path / "n.dump"
    lines = [" ".join(texts[i:i + 4]) for i in range(0, n, 4)]
    path.write_text(f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ENTRIES\n{len(lines)}\nITEM: BOX BOUNDS pp pp ff\n"
                    f"0 1\n0 1\n0 1\nITEM: ENTRIES a b c d\n" + "\n".join(lines) + "\n")
    got = dumps.read_dump(path).data.ravel()
    np.testing.assert_array_equal(got, [float(t) for t in texts[:n]])


def test_chunks_are_joined_and_the_shared_boundary_step_is_dropped(tmp_path, rng, parser):
    rows = particle_rows(rng, 10)
    write_snapshots(tmp_path / "a.dump", PARTICLE_HEADER, "ATOMS", [(0, rows), (10, rows + 1)])
    write_snapshots(tmp_path / "b.dump", PARTICLE_HEADER, "ATOMS", [(10, rows + 1), (20, rows + 2)])
    dump = dumps.read_particles([tmp_path / "a.dump", tmp_path / "b.dump"])
    assert list(dump.timesteps) == [0, 10, 20]
    np.testing.assert_array_equal(dump.rows(2), rows + 2)


def test_generic_contact_columns_are_mapped_by_index(tmp_path, rng, parser):
    rows = rng.normal(size=(7, 16))
    header = " ".join(f"c_pgl[{k}]" for k in range(1, 17))
    write_snapshots(tmp_path / "c.dump", header, "ENTRIES", [(5, rows), (6, rows[:0])])
    dump = dumps.read_contacts(tmp_path / "c.dump")
    assert dump.columns == dumps.CONTACT_COLUMNS
    assert list(dump.counts) == [7, 0]
    np.testing.assert_array_equal(dump.column("fz"), rows[:, 11])
    # A custom order, as a list of physical names of c_ID[1], c_ID[2], ...
    custom = list(reversed(dumps.CONTACT_COLUMNS))
    np.testing.assert_array_equal(dumps.read_contacts(tmp_path / "c.dump", names=custom).column("fz"), rows[:, 4])


def test_physical_and_lammps_style_contact_headers(tmp_path, rng, parser):
    rows = rng.normal(size=(3, 10))
    write_snapshots(tmp_path / "c.dump", "fx fy fz x1 y1 z1 x2 y2 z2 periodic", "ENTRIES", [(1, rows)])
    np.testing.assert_array_equal(dumps.read_contacts(tmp_path / "c.dump").column("x1"), rows[:, 3])
    write_snapshots(tmp_path / "d.dump", "pos1x pos1y pos1z pos2x pos2y pos2z patom1 patom2 f_x f_y f_z", "ENTRIES",
                    [(1, rng.normal(size=(2, 11)))])
    assert dumps.read_contacts(tmp_path / "d.dump").columns[:8] == dumps.CONTACT_COLUMNS[:8]


def test_the_contact_columns_agree_with_the_dem_stage():
    from pipeline.dem.planar_run import CONTACT_COLUMNS

    assert tuple(CONTACT_COLUMNS) == dumps.CONTACT_COLUMNS


def expect_error(path: Path, line: int, words: str) -> None:
    with pytest.raises(dumps.DumpError) as err:
        dump = dumps.read_dump(path)
        # nan and inf parse; a column that is read is then refused with its line (check_finite)
        dumps.check_finite(dump, dump.columns)
    message = str(err.value)
    assert message.startswith(f"{path}:{line}:"), message
    assert words in message, message


def lines_of(rng: np.random.Generator, path: Path) -> list[str]:
    write_snapshots(path, PARTICLE_HEADER, "ATOMS", [(0, particle_rows(rng, 4)), (1, particle_rows(rng, 4))], fmt="%g")
    return path.read_text().splitlines()


def test_truncated_file_names_file_and_line(tmp_path, rng, parser):
    path = tmp_path / "t.dump"
    lines = lines_of(rng, path)
    path.write_text("\n".join(lines[:-2]) + "\n")  # the second snapshot loses its last 2 lines
    expect_error(path, 25, "truncated")
    path.write_text("\n".join(lines[:-1]) + "\n" + lines[-1][:20])  # cut in the middle of a line
    expect_error(path, 26, "too few columns")
    path.write_text("\n".join(lines[:15]) + "\n")  # cut inside the second header
    expect_error(path, 16, "truncated")


def test_malformed_and_nan_values_name_the_line(tmp_path, rng, parser):
    path = tmp_path / "m.dump"
    lines = lines_of(rng, path)
    for bad, words in (("1.2.3", "not a number"), ("nan", "non-finite"), ("-inf", "non-finite"), ("abc", "not a number"),
                       # strtod reads C99 hex floats and nan(...); no dump writes them and float()
                       # refuses them (hypothesis found "0x.0", an 'x' put into "0.0", read as 0.0)
                       ("0x.0", "not a number"), ("0x1p3", "not a number"), ("nan(1)", "not a number")):
        edited = list(lines)
        words_ = edited[11].split()
        words_[5] = bad
        edited[11] = " ".join(words_)
        path.write_text("\n".join(edited) + "\n")
        expect_error(path, 12, words)
    edited = list(lines)
    edited[11] += " 7"
    path.write_text("\n".join(edited) + "\n")
    expect_error(path, 12, "too many columns")
    edited = list(lines)
    edited.insert(13, edited[12])  # one line more than NUMBER OF ATOMS says
    path.write_text("\n".join(edited) + "\n")
    expect_error(path, 14, "more lines")


def test_wrong_headers_are_refused(tmp_path, rng):
    path = tmp_path / "h.dump"
    lines = lines_of(rng, path)
    edited = list(lines)
    edited[2] = "ITEM: NUMBER OF BONDS"
    path.write_text("\n".join(edited) + "\n")
    expect_error(path, 3, "ATOMS or ENTRIES")
    edited = list(lines)
    edited[1] = "12x"
    path.write_text("\n".join(edited) + "\n")
    expect_error(path, 2, "timestep")
    path.write_text("hello\n")
    expect_error(path, 1, "ITEM: TIMESTEP")
    path.write_text("")
    expect_error(path, 1, "empty")
    with pytest.raises(dumps.DumpError, match="not found"):
        dumps.read_dump(tmp_path / "missing.dump")


def test_missing_columns_are_named(tmp_path, rng):
    path = tmp_path / "p.dump"
    write_snapshots(path, "id type x y z vx vy vz", "ATOMS", [(0, rng.normal(size=(2, 8)))])
    with pytest.raises(dumps.DumpError, match=r"p.dump:9: missing column\(s\) radius mass"):
        dumps.read_particles(path)
    with pytest.raises(dumps.DumpError, match="not a contact dump"):
        dumps.read_contacts(path)


def test_scaled_coordinates_and_diameter_are_converted(tmp_path, rng):
    rows = rng.random((5, 8))
    write_snapshots(tmp_path / "s.dump", "xs ys zs vx vy vz diameter mass", "ATOMS", [(0, rows)])
    dump = dumps.read_particles(tmp_path / "s.dump")
    np.testing.assert_allclose(dump.column("y"), 0.02 * rows[:, 1])
    np.testing.assert_allclose(dump.column("z"), -0.001 + 0.051 * rows[:, 2])
    np.testing.assert_allclose(dump.column("radius"), rows[:, 6] / 2)


@pytest.mark.liggghts
def test_real_liggghts_dumps(rheometer_run: Path):
    import json

    SAMPLE = rheometer_run
    run = json.loads((SAMPLE / "run.json").read_text())
    particles = dumps.read_particles([SAMPLE / p for p in run["particle_dumps"]])
    contacts = dumps.read_contacts([SAMPLE / p for p in run["contact_dumps"]], run["contact_columns"])
    assert np.array_equal(particles.timesteps, contacts.timesteps)
    assert np.all(particles.counts == run["particle_count"])
    ids = set(particles.column("id").astype(int))
    assert set(contacts.column("id1").astype(int)) <= ids
    # The contact's own positions are those of the particles it names.
    first = particles.rows(0)
    by_id = {int(i): k for k, i in enumerate(first[:, particles.index("id")])}
    c = contacts.rows(0)
    k1 = [by_id[int(i)] for i in c[:, contacts.index("id1")]]
    np.testing.assert_allclose(c[:, contacts.index("z1")], first[k1, particles.index("z")], rtol=1e-5)


def test_store_round_trip_is_exact(tmp_path, rng):
    import json

    from pipeline.dumps import store as dump_store

    rows = particle_rows(rng, 20)
    (tmp_path / "dumps").mkdir()
    write_snapshots(tmp_path / "dumps/p0.dump", PARTICLE_HEADER, "ATOMS", [(0, rows), (10, rows + 1)])
    write_snapshots(tmp_path / "dumps/p1.dump", PARTICLE_HEADER, "ATOMS", [(10, rows + 1), (20, rows + 2)])
    header = " ".join(f"c_pgl[{k}]" for k in range(1, 17))
    contacts = rng.normal(size=(6, 16))
    write_snapshots(tmp_path / "dumps/c0.dump", header, "ENTRIES", [(0, contacts), (10, contacts[:2])])
    write_snapshots(tmp_path / "dumps/c1.dump", header, "ENTRIES", [(10, contacts[:2]), (20, contacts[:0])])
    (tmp_path / "run.json").write_text(json.dumps({
        "particle_dumps": ["dumps/p0.dump", "dumps/p1.dump"], "contact_dumps": ["dumps/c0.dump", "dumps/c1.dump"],
        "contact_columns": list(dumps.CONTACT_COLUMNS)}))
    assert dump_store.main([str(tmp_path)]) == 0
    parsed_p, parsed_c = dump_store.parse_run(tmp_path)
    stored_p, stored_c = dump_store.read_store(tmp_path / dump_store.STORE_NAME)
    for a, b in ((parsed_p, stored_p), (parsed_c, stored_c)):
        assert a.columns == b.columns and a.kind == b.kind and a.boundary == b.boundary
        np.testing.assert_array_equal(a.data, b.data)
        np.testing.assert_array_equal(a.offsets, b.offsets)
        np.testing.assert_array_equal(a.timesteps, b.timesteps)
        np.testing.assert_array_equal(a.boxes, b.boxes)
    assert list(stored_c.counts) == [6, 2, 0]
    _, loaded_p, _ = dump_store.load_run(tmp_path)
    np.testing.assert_array_equal(loaded_p.data, parsed_p.data)
