"""Action = reaction over a whole sheared bed, with the real LIGGGHTS binary (pipeline/dem/force_balance.py).

A small bed (200 grains between two rough walls in a 5 x 5 d periodic cell, gravity, the reduced
workflow's material) is poured with the planar-shear fill template and sheared for one short chunk
with its shear template, each rendered as the pipeline renders them. Law: every contact's two forces
cancel, so the pair forces summed over all atoms are zero to round-off in every sample.

Controls, which show that the check sees the defects the templates avoid (docs/dem.md, "Action and
reaction"): the same chunk with the top wall as a ``fix rigid`` body (LIGGGHTS 3.8 gives its ghost
grains the body mass truncated to an integer, 0 here), and the same bed poured without storing the
contact history before the top wall's grains are created. Each must leave sums far above round-off.
"""
from __future__ import annotations

import math
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from pipeline.common.config import size_classes
from pipeline.dem import force_balance
from pipeline.dem import liggghts_render as render
from pipeline.dem.rough_wall import layer_include, random_layer

pytestmark = pytest.mark.liggghts

D = 0.002  # m, mean grain diameter
RHO = 2500.0  # kg/m3
CELL = 5.0 * D
SIZES = size_classes(D, 0.2, 5)
N_GRAINS = 200
DT = 4.226806400945699e-06  # s: the reduced workflow's step for its Young's modulus
MATERIAL = {
    "Lx": CELL, "Ly": CELL, "skin": 0.1 * D, "youngs_modulus": 26635755.85519609, "poisson_ratio": 0.3,
    "restitution_matrix": [0.5] * 16, "friction_matrix": [0.5] * 16, "dt": DT,
}
Z_BOTTOM = 0.5 * max(SIZES)
PRESSURE = 400.0  # Pa on the top wall
DAMPING = 0.13  # N s/m on the top wall's vertical speed (the reduced workflow's, 10 % of critical)

# The top wall as the templates had it before issue 44: one fix rigid body.
RIGID_WALL = """variable        wall_fz atom -${load_per_grain}-${wall_damping_per_grain}*vz
fix load top addforce 0.0 0.0 v_wall_fz
fix wall top rigid single force * off off on torque * off off off
"""
# The fill's lines that store the contact history before the top wall's grains are created.
HISTORY_STORE = "write_restart   settled.restart\nshell           rm settled.restart\n"


def liggghts(run_dir: Path, stage: str) -> str:
    proc = subprocess.run(["liggghts", "-in", f"in.{stage}", "-log", f"{stage}.log"], cwd=run_dir,
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 0 and "ERROR" not in proc.stdout, proc.stdout[-3000:]
    return (run_dir / f"{stage}.log").read_text()


def pour(run_dir: Path, store_history: bool = True) -> tuple[float, int]:
    """A settled bed with both walls (fill.restart); returns the top wall's height (m) and grain count."""
    if shutil.which("liggghts") is None:
        pytest.fail("LIGGGHTS is not installed: run scripts/install.sh")
    render.copy_templates("planar_shear", run_dir)
    if not store_history:
        fill = run_dir / "fill.in"
        assert HISTORY_STORE in fill.read_text()
        fill.write_text(fill.read_text().replace(HISTORY_STORE, ""))
    rng = np.random.default_rng(4404)
    bottom = random_layer(CELL, CELL, SIZES, rng)
    top = random_layer(CELL, CELL, SIZES, rng)
    (run_dir / "bottom_wall.in").write_text(layer_include(bottom, 2, Z_BOTTOM, RHO, 1))
    (run_dir / "top_wall.in").write_text(layer_include(top, 3, "${z_top_wall}", RHO, len(bottom) + N_GRAINS + 1))
    (run_dir / "grains.in").write_text(render.grains_include(D, 0.2, 5, RHO, [15485863, 32452843, 49979687, 67867967, 86028121], 104395301))
    # As the pipeline pours (pipeline/dem/planar_run.py): a loose column at solid fraction 0.25, a drag
    # with the free-fall time, settled when the kinetic energy is 1e-3 m g d per grain.
    m_grain = RHO * math.pi / 6.0 * float(np.mean(np.asarray(SIZES) ** 3))
    lz = N_GRAINS * m_grain / RHO / (0.25 * CELL**2) + 4.0 * D
    fall_time = math.sqrt(2.0 * lz / 9.81)
    chunk = math.ceil(fall_time / 8.0 / DT)
    render.render_stage(run_dir, "fill", "fill.in", MATERIAL | {
        "Lz_box": lz, "z_insert_low": Z_BOTTOM + max(SIZES), "top_wall_clearance": max(SIZES) + 0.01 * D,
        "n_grains": N_GRAINS, "seed_insert": 16681579, "g_fill": 9.81, "thermo_every": chunk,
        "settle_chunk_steps": chunk, "settle_max_chunks": 160, "fill_drag": m_grain / fall_time,
        "ke_settled": 1e-3 * N_GRAINS * m_grain * 9.81 * D})
    log = liggghts(run_dir, "fill")
    return float(re.findall(r"TOP_WALL_Z (\S+)", log)[-1]), len(top)


def shear(run_dir: Path, z_top: float, n_top: int, stage: str, template: str = "shear.in") -> dict:
    """One chunk of shear from the fill; returns the pair-force check over its samples."""
    render.render_stage(run_dir, stage, template, MATERIAL | {
        "restart_in": "fill.restart", "restart_out": f"{stage}.restart", "first_chunk": 1,
        "z_bottom_wall": Z_BOTTOM, "z_top_wall": z_top, "wall_speed": 0.1, "gravity": 9.81,
        "load_per_grain": PRESSURE * CELL**2 / n_top, "wall_damping_per_grain": DAMPING / n_top,
        "delta_column": 13, "series_nevery": 20, "series_nrepeat": 10, "series_every": 200,
        "series_file": f"series_{stage}.txt", "pairsum_file": f"pairsum_{stage}.txt",
        "pairforce_file": force_balance.pair_force_file(stage), "thermo_every": 2000, "chunk_steps": 6000,
        "dump_every": 0, "particle_dump": "p.dump", "contact_dump": "c.dump",
        "contact_columns": [f"c_pgl[{k}]" for k in range(1, 17)]})
    (run_dir / "series").mkdir(exist_ok=True)
    liggghts(run_dir, stage)
    wall = np.loadtxt(run_dir / f"series_{stage}.txt")
    check = force_balance.record(run_dir, [stage], shear_force=float(wall[:, 4].mean()))
    assert check is not None
    # The wall did shear the bed (it starts just above it): over the chunk's second half it carried
    # its load and a shear force.
    late = wall[len(wall) // 2:]
    load = PRESSURE * CELL**2
    assert late[:, 5].mean() > 0.5 * load and abs(late[:, 4].mean()) > 0.05 * load, late[:, 4:6].mean(axis=0)
    return check


@pytest.fixture(scope="module")
def bed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, float, int]:
    run_dir = tmp_path_factory.mktemp("force_balance")
    z_top, n_top = pour(run_dir)
    return run_dir, z_top, n_top


def test_pair_forces_of_a_sheared_bed_sum_to_round_off(bed: tuple[Path, float, int]) -> None:
    check = shear(*bed, "shear")
    assert check["samples"] == 30
    assert check["at_round_off"], check


def test_a_rigid_top_wall_breaks_the_balance(bed: tuple[Path, float, int]) -> None:
    run_dir = bed[0]
    text = (run_dir / "shear.in").read_text()
    assert "include         top_wall_drive.in\n" in text
    (run_dir / "shear_rigid.in").write_text(text.replace("include         top_wall_drive.in\n", RIGID_WALL))
    check = shear(*bed, "rigid", template="shear_rigid.in")
    # Far above round-off: the defect the top wall's formulation removes (1e-4 to 1e-3 of sum |f| on
    # the default beds); 1e3 times the round-off tolerance still fails a sum at round-off.
    assert max(check[f"max_sum_over_abs_{a}"] for a in "xyz") > 1e3 * force_balance.ROUND_OFF, check


def test_the_fill_without_storing_the_history_breaks_the_balance(tmp_path: Path) -> None:
    z_top, n_top = pour(tmp_path, store_history=False)
    check = shear(tmp_path, z_top, n_top, "shear")
    assert max(check[f"max_sum_over_abs_{a}"] for a in "xyz") > 1e3 * force_balance.ROUND_OFF, check
