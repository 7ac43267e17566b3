"""``cases.<case>.packing_from``: a planar run's grains placed where another root's run settled them
(pipeline/dem/adopted_packing.py). The real engines adopt each other's packings and keep them at
rest; a source that is not the same run is refused, naming the file."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pipeline.common.config import load_config, run_config
from pipeline.dem import adopted_packing
from pipeline.dem.lifecycle import read_settled
from pipeline.dem.liggghts_log import DEMRunError
from pipeline.dem.planar_run import PlanarShearRun

REPO = Path(__file__).resolve().parents[3]
CI = REPO / "config" / "ci.yaml"


def settled_frame() -> pd.DataFrame:
    """Two wall grains (type 2, ids 1-2) and three flowing grains (type 1) listed out of id order."""
    return pd.DataFrame({"id": [1, 2, 5, 3, 4], "type": [2, 2, 1, 1, 1],
                         "x": [0.001, 0.003, 0.0025, 0.0005, 0.0015], "y": [0.001, 0.002, 0.0, 0.001, 0.002],
                         "z": [0.0012, 0.0012, 0.005, 0.003, 0.004],
                         "radius": [0.001, 0.0008, 0.0012, 0.0009, 0.001], "mass": [0.0] * 5})


def test_the_include_creates_the_flowing_grains_in_id_order_with_their_diameters() -> None:
    text = adopted_packing.packing_include(settled_frame(), first_id=3, rho_s=2500.0).splitlines()
    created = [line for line in text if line.startswith("create_atoms")]
    assert created == ["create_atoms 1 single 0.0005 0.001 0.003 units box",
                       "create_atoms 1 single 0.0015 0.002 0.004 units box",
                       "create_atoms 1 single 0.0025 0.0 0.005 units box"]
    assert "set atom 3 diameter 0.0018" in text and "set atom 5 diameter 0.0024" in text
    assert text.count("set atom 4 density 2500.0") == 1
    # A group defined before the grains existed does not hold them.
    assert text[-1] == "group flow type 1"


def test_a_source_with_another_count_or_bottom_wall_is_refused() -> None:
    frame, path = settled_frame(), Path("other/dem/shear_gravity/r1/settled.dump")
    x, y = np.array([0.001, 0.003]), np.array([0.001, 0.002])
    adopted_packing.check_source(frame, path, 3, x, y)
    with pytest.raises(DEMRunError, match=r"settled.dump: 3 flowing grains, the case asks for 4"):
        adopted_packing.check_source(frame, path, 4, x, y)
    with pytest.raises(DEMRunError, match=r"bottom wall's grain 2 sits 0.0001 m"):
        adopted_packing.check_source(frame, path, 3, x, y + np.array([0.0, 1e-4]))
    with pytest.raises(DEMRunError, match=r"bottom wall has 2 grains, this run's 3"):
        adopted_packing.check_source(frame, path, 3, np.append(x, 0.0), np.append(y, 0.0))


def test_only_liggghts_pour_lines_are_removed_and_a_changed_template_is_refused() -> None:
    template = (REPO / "liggghts_inputs" / "planar_shear" / "fill.in").read_text()
    out = adopted_packing.without_pour(template, "liggghts", Path("fill.in"))
    removed = [a for a, b in zip(template.splitlines(), out.splitlines()) if a != b]
    assert len(removed) == 2 and removed[0].split()[:2] == ["fix", "ins"] and removed[1].split() == ["unfix", "ins"]
    assert len(out.splitlines()) == len(template.splitlines())
    lammps = (REPO / "lammps_inputs" / "planar_shear" / "fill.in").read_text()
    assert adopted_packing.without_pour(lammps, "lammps", Path("fill.in")) == lammps
    with pytest.raises(DEMRunError, match=r"fill.in: expected one command each of fix ins and unfix ins, found 1"):
        adopted_packing.without_pour(template.replace("ins\n", "pour\n"), "liggghts", Path("fill.in"))


def settled_bed(root: Path, engine: str, packing_from: Path | None, seed: int | None = None,
                mpi_ranks: int | None = None) -> PlanarShearRun:
    """Pour (or adopt) ci.yaml's shear_gravity r1 under ``root`` with ``engine``, damping off
    (``seed`` and ``mpi_ranks``: another realisation than ci.yaml's)."""
    config = run_config(load_config(CI), "shear_gravity", "r1")
    config["dem"]["engine"] = engine
    if seed is not None:
        config["seed"] = seed
    if mpi_ranks is not None:
        config["dem"]["mpi_ranks"] = mpi_ranks
    config["material"]["tangential_damping"] = False
    if packing_from is not None:
        config["cases"]["shear_gravity"]["packing_from"] = str(packing_from)
    run = PlanarShearRun(config, "shear_gravity", "r1", root / "dem" / "shear_gravity" / "r1")
    run.run_dir.mkdir(parents=True)
    run._load_state()
    run._fill()
    return run


def coulomb_stretch_over_d(material: dict) -> float:
    """The tangential spring's stretch at the Coulomb limit, mu F_n / k_t, of a Hertz-Mindlin
    contact of two like grains at the design overlap delta, in d:
    F_n = 4/3 E* sqrt(R* delta) delta and k_t = 8 G* sqrt(R* delta), so mu F_n / k_t =
    mu delta E* / (6 G*) = mu delta (2 - nu) / (3 (1 - nu)) (E* / G* = 2 (2 - nu) / (1 - nu)).
    A contact that lost its spring slides at most this far before friction holds it again."""
    nu = float(material["poisson_ratio"])
    return float(material["friction"]) * float(material["design_overlap"]) * (2.0 - nu) / (3.0 * (1.0 - nu))


def packing_shifts(source: PlanarShearRun, adopted: PlanarShearRun) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """How far each flowing grain of ``source``'s settled packing moved when ``adopted`` settled it
    again, in d: the shifts, their z parts, which grains lie 2 d or more below the top (buried),
    the bound on a load-bearing grain's shift (the Coulomb stretch times the layers below the
    deepest buried grain's height) and the smallest grain's radius."""
    d = float(adopted.mat["d"])
    before = read_settled(source.run_dir / "settled.dump")
    after = read_settled(adopted.run_dir / "settled.dump")
    grains = [frame[frame["type"] == 1].sort_values("id").reset_index(drop=True) for frame in (before, after)]
    np.testing.assert_allclose(grains[1]["radius"], grains[0]["radius"], rtol=1e-5)
    # x and y are periodic: a grain on a face may be listed on the other side.
    cell = np.array([adopted.case["cell_x"], adopted.case["cell_y"]]) * d
    dxy = np.array([grains[1][a] - grains[0][a] for a in "xy"]).T
    dxy -= cell * np.round(dxy / cell)
    dz = (grains[1]["z"] - grains[0]["z"]).to_numpy() / d
    shift = np.sqrt((dxy**2).sum(axis=1) / d**2 + dz**2)
    z = grains[0]["z"].to_numpy()
    buried = z < z.max() - 2.0 * d
    layers = (z[buried].max() - (z.min() - grains[0]["radius"].min())) / d
    return shift, dz, buried, coulomb_stretch_over_d(adopted.mat) * layers, float(grains[0]["radius"].min()) / d


@pytest.mark.parametrize("pourer, shearer", [("liggghts", "lammps"), ("lammps", "liggghts")])
def test_each_engine_keeps_the_other_engines_settled_packing_at_rest(tmp_path: Path, pourer: str, shearer: str) -> None:
    """A packing at rest under one engine's law is at rest under the other's (one law, damping off).
    Adopted grains start without their tangential springs (no dump holds the contact history), so a
    grain at the free surface, held by friction alone, may roll into another place (seen: 18 of 500
    by 0.02-0.23 d, all within 0.3 d of the top). A grain 2 d or more below the top carries the
    weight above it through its contacts, whose normal overlaps are the same under both laws; each
    contact on its way down to the bottom wall slides at most the spring's stretch at the Coulomb
    limit (:func:`coulomb_stretch_over_d`, 0.0008 d here) before friction holds it again, so a
    grain moves at most that stretch times the layers below it (the bound: at the deepest buried
    grain's height, 0.014 d here). Within it: 95 % of the buried grains and the bed's mean height.
    A rattler (a caged grain carrying nothing: past the bound, fewer than 5 % of the buried grains)
    may move inside its cage, never out of it: each less than the smallest grain's radius. Over
    16 realisations (seeds 7-10, both directions, one and two ranks:
    ``benchmarks/adopted_packing_spread.py``, benchmarks/records/adopted_packing_spread_2026-12-07.txt)."""
    source = settled_bed(tmp_path / "source", pourer, None)
    adopted = settled_bed(tmp_path / "adopted", shearer, tmp_path / "source")
    assert adopted.state["fill"]["packing_from"]["path"].endswith("source/dem/shear_gravity/r1/settled.dump")
    shift, dz, buried, bound, smallest_radius = packing_shifts(source, adopted)
    assert buried.sum() > 0.8 * len(buried)
    assert 0.005 < bound < 0.05, bound  # the ci bed's: a wrong material or bed would show here
    assert np.percentile(shift[buried], 95) < bound, f"95 % shift {np.percentile(shift[buried], 95):.4f} d, bound {bound:.4f} d"
    assert abs(dz.mean()) < bound, f"the bed's mean height moved by {dz.mean():.4f} d, bound {bound:.4f} d"
    rattlers = shift[buried] > bound
    assert rattlers.mean() < 0.05, f"{rattlers.sum()} of {buried.sum()} buried grains moved past {bound:.4f} d"
    assert shift[buried].max() < smallest_radius, f"largest shift below the surface layer {shift[buried].max():.4f} d"


@pytest.mark.parametrize("run_dir_name", ["fill-r1", "I0.07-P600-r1"])
def test_the_rheometers_states_adopt_their_replicas_shared_fill(tmp_path: Path, run_dir_name: str) -> None:
    """The rheometer's states of one replica share a fill: poured as ``fill-r1`` (the workflow) or by
    a state alone from the fill's seed, its source is the other root's ``fill-r1``, never a state's
    own folder (a state adopting a fill has none of its own pour)."""
    config = run_config(load_config(CI), "rheometer", "I0.07-P600-r1")
    config["cases"]["rheometer"]["packing_from"] = str(tmp_path / "other")
    run = PlanarShearRun(config, "rheometer", "I0.07-P600-r1", tmp_path / "dem" / "rheometer" / run_dir_name)
    with pytest.raises(DEMRunError, match=r"no settled packing .*other/dem/rheometer/fill-r1/settled.dump"):
        run._adopted_packing(None, first_id=1)


def test_a_folder_that_is_neither_the_run_nor_its_fill_is_refused(tmp_path: Path) -> None:
    config = run_config(load_config(CI), "rheometer", "I0.07-P600-r1")
    config["cases"]["rheometer"]["packing_from"] = str(tmp_path / "other")
    run = PlanarShearRun(config, "rheometer", "I0.07-P600-r1", tmp_path / "dem" / "rheometer" / "fill-r2")
    with pytest.raises(DEMRunError, match=r"packing_from is for a planar case's fills .* not for fill-r2"):
        run._adopted_packing(None, first_id=1)
