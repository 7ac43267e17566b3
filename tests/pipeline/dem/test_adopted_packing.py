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


def _fill(root: Path, engine: str, packing_from: Path | None) -> PlanarShearRun:
    """Pour (or adopt) ci.yaml's shear_gravity r1 under ``root`` with ``engine``, damping off."""
    config = run_config(load_config(CI), "shear_gravity", "r1")
    config["dem"]["engine"] = engine
    config["material"]["tangential_damping"] = False
    if packing_from is not None:
        config["cases"]["shear_gravity"]["packing_from"] = str(packing_from)
    run = PlanarShearRun(config, "shear_gravity", "r1", root / "dem" / "shear_gravity" / "r1")
    run.run_dir.mkdir(parents=True)
    run._load_state()
    run._fill()
    return run


@pytest.mark.parametrize("pourer, shearer", [("liggghts", "lammps"), ("lammps", "liggghts")])
def test_each_engine_keeps_the_other_engines_settled_packing_at_rest(tmp_path: Path, pourer: str, shearer: str) -> None:
    """A packing at rest under one engine's law is at rest under the other's (one law, damping off).
    Adopted grains start without their tangential springs (no dump holds the contact history), so a
    grain at the free surface, held by friction alone, may roll into another place (seen: 18 of 500
    by 0.02-0.23 d, all within 0.3 d of the top); a grain 2 d or more below the top carries the
    weight above it through its normal contacts and moves only as the overlaps (0.002 d at the
    design pressure) settle again, but for rattlers (0.04 d seen). The bed's mean height stays to
    0.005 d (0.0016 d seen)."""
    source = _fill(tmp_path / "source", pourer, None)
    adopted = _fill(tmp_path / "adopted", shearer, tmp_path / "source")
    assert adopted.state["fill"]["packing_from"]["path"].endswith("source/dem/shear_gravity/r1/settled.dump")
    d = float(adopted.mat["d"])
    before = read_settled(source.run_dir / "settled.dump")
    after = read_settled(adopted.run_dir / "settled.dump")
    grains = [frame[frame["type"] == 1].sort_values("id").reset_index(drop=True) for frame in (before, after)]
    np.testing.assert_allclose(grains[1]["radius"], grains[0]["radius"], rtol=1e-5)
    # x and y are periodic: a grain on a face may be listed on the other side.
    cell = np.array([adopted.case["cell_x"], adopted.case["cell_y"]]) * d
    dxy = np.array([grains[1][a] - grains[0][a] for a in "xy"]).T
    dxy -= cell * np.round(dxy / cell)
    dz = (grains[1]["z"] - grains[0]["z"]).to_numpy()
    shift = np.sqrt((dxy**2).sum(axis=1) + dz**2)
    buried = grains[0]["z"].to_numpy() < grains[0]["z"].max() - 2.0 * d
    assert buried.sum() > 0.8 * len(buried)
    # The load-bearing grains: 95 % within 0.005 d (seen 0.001 d at 90 %); a rattler (a caged grain
    # carrying nothing, a few % of a random packing) may shift inside its cage, never out of it.
    assert np.percentile(shift[buried], 95) < 0.005 * d, f"95 % shift {np.percentile(shift[buried], 95) / d:.4f} d"
    assert shift[buried].max() < 0.1 * d, f"largest shift below the surface layer {shift[buried].max() / d:.4f} d"
    assert abs(dz.mean()) < 0.005 * d, f"the bed's mean height moved by {dz.mean() / d:.4f} d"


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
