"""The coarse-graining command on dumps as LIGGGHTS and LAMMPS users keep them, made by the real LIGGGHTS."""
from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from pipeline.coarse_graining import dumps_cli as cg

pytestmark = pytest.mark.workflow


def rewrite(source: Path, target: Path, keep: list[str], opener=open) -> None:
    """The dump with only the ``keep`` columns, in that order (a LAMMPS user's own dump custom)."""
    lines = source.read_text().splitlines()
    out, k = [], 0
    while k < len(lines):
        line = lines[k]
        if line.startswith("ITEM: ATOMS"):
            names = line.split()[2:]
            order = [names.index(c) for c in keep]
            out.append("ITEM: ATOMS " + " ".join(keep))
            count = int(lines[k - 5])  # ITEM: NUMBER OF ATOMS, its count, then the box header and 3 bounds
            for row in lines[k + 1:k + 1 + count]:
                values = row.split()
                out.append(" ".join(values[i] for i in order))
            k += 1 + count
        else:
            out.append(line)
            k += 1
    with opener(target, "wt") as handle:
        handle.write("\n".join(out) + "\n")


def test_gzip_dump_without_mass_in_another_column_order_matches_the_plain_dump(shear_gravity_run: Path,
                                                                               tmp_path: Path) -> None:
    dump = sorted((shear_gravity_run / "dumps").glob("particles_*.dump"))[0]
    plain = tmp_path / "plain.nc"
    assert cg.main([str(dump), "--out", str(plain), "--rho-s", "2500"]) == 0
    own = tmp_path / "own.dump.gz"
    rewrite(dump, own, ["radius", "vz", "z", "id", "type", "vx", "x", "y", "vy"], opener=gzip.open)
    mine = tmp_path / "own.nc"
    assert cg.main([str(own), "--out", str(mine), "--rho-s", "2500"]) == 0
    a, b = xr.open_dataset(plain), xr.open_dataset(mine)
    # LIGGGHTS prints masses to 6 significant digits; the masses from radius and rho_s are exact:
    # mass-weighted fields agree to the printing, 5e-6, and nu (no mass) to round-off.
    np.testing.assert_allclose(b["nu"].values, a["nu"].values, rtol=1e-12)
    for name in ("rho", "u_x", "sigma_zz_kinetic", "granular_temperature"):
        np.testing.assert_allclose(b[name].values, a[name].values, rtol=0, atol=5e-6 * float(np.abs(a[name]).max()))
    a.close(), b.close()


def test_missing_mass_or_radius_names_the_option(shear_gravity_run: Path, tmp_path: Path, capsys) -> None:
    dump = sorted((shear_gravity_run / "dumps").glob("particles_*.dump"))[0]
    no_mass = tmp_path / "a.dump"
    rewrite(dump, no_mass, ["id", "type", "x", "y", "z", "vx", "vy", "vz", "radius"])
    assert cg.main([str(no_mass), "--out", str(tmp_path / "a.nc")]) == 1
    assert "--rho-s" in capsys.readouterr().err
    no_radius = tmp_path / "b.dump"
    rewrite(dump, no_radius, ["id", "type", "x", "y", "z", "vx", "vy", "vz", "mass"])
    assert cg.main([str(no_radius), "--out", str(tmp_path / "b.nc")]) == 1
    assert "--diameter" in capsys.readouterr().err
    assert cg.main([str(no_radius), "--out", str(tmp_path / "b.nc"), "--diameter", "0.002"]) == 0
    assert not (tmp_path / "a.nc").exists()
