"""``material.tangential_damping`` (pipeline/dem/contact_law.py, docs/dem.md "Two engines"): absent or
true, every engine's copied templates are the repository's byte for byte (no run's rendered input
changes); false, every occurrence of the contact law is rewritten, in both engines, and LIGGGHTS
takes the rewritten wall line (a one-grain run with its real binary)."""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from pipeline.common.config import load_config
from pipeline.dem import contact_law
from pipeline.dem import liggghts_render as render
from pipeline.dem.engines import make_engine
from pipeline.dem.planar_run import PlanarShearRun

REPO = Path(__file__).resolve().parents[3]
CI = REPO / "config" / "ci.yaml"


def _engines(material: dict) -> list:
    dem = load_config(CI)["dem"]
    return [make_engine(dem | {"engine": name}, material) for name in ("liggghts", "lammps")]


@pytest.mark.parametrize("material", [{}, {"tangential_damping": True}, None])
def test_absent_or_true_copies_the_templates_byte_for_byte(tmp_path: Path, material: dict | None) -> None:
    for engine in _engines(material):
        for geometry in ("planar_shear", "two_grain", *(("intruder",) if engine.name == "liggghts" else ())):
            out = tmp_path / engine.name / geometry
            engine.copy_templates(geometry, out)
            sources = render.template_files(geometry) if engine.name == "liggghts" else engine.template_files(geometry)
            for path in sources:
                assert (out / path.name).read_bytes() == path.read_bytes(), (engine.name, path)


def test_false_rewrites_every_contact_law_line_in_both_engines(tmp_path: Path) -> None:
    liggghts, lammps = _engines({"tangential_damping": False})
    liggghts.copy_templates("planar_shear", tmp_path / "liggghts")
    lammps.copy_templates("planar_shear", tmp_path / "lammps")
    for name in ("materials.in", "fill.in"):
        lines = [line.split("#", 1)[0] for line in (tmp_path / "liggghts" / name).read_text().splitlines()]
        law = [line for line in lines if contact_law.LIGGGHTS_MODEL in line]
        assert law and all(line.rstrip().endswith("tangential_damping off") for line in law), name
        text = (tmp_path / "lammps" / name).read_text()
        assert contact_law.LAMMPS_MINDLIN not in text and contact_law.LAMMPS_UNDAMPED in text, name
    # The stages read no variable the law with damping does not: the planar run's stages still render.
    on_liggghts, on_lammps = _engines({})
    on_liggghts.copy_templates("planar_shear", tmp_path / "liggghts_on")
    on_lammps.copy_templates("planar_shear", tmp_path / "lammps_on")
    for name in ("liggghts", "lammps"):
        for stage in ("fill.in", "shear.in"):
            assert render.variables_read(tmp_path / name / stage) <= render.variables_read(tmp_path / f"{name}_on" / stage)
    # A second rewrite is a no-op (the option is not appended twice).
    text = (tmp_path / "liggghts" / "materials.in").read_text()
    assert contact_law.liggghts_undamped(text) == (text, 0)


def test_a_planar_run_takes_the_switch_from_its_material(tmp_path: Path) -> None:
    config = load_config(CI)
    assert PlanarShearRun(config, "shear_gravity", "r1", tmp_path / "a").engine.tangential_damping is True
    config["material"]["tangential_damping"] = False
    assert PlanarShearRun(config, "shear_gravity", "r1", tmp_path / "b").engine.tangential_damping is False
    with pytest.raises(contact_law.ContactLawError, match="true or false"):
        contact_law.tangential_damping({"tangential_damping": "off"})


def test_a_template_the_switch_does_not_know_is_refused(tmp_path: Path) -> None:
    (tmp_path / "materials.in").write_text("pair_style gran model hooke tangential history\n")
    with pytest.raises(contact_law.ContactLawError, match="not the one the switch rewrites"):
        contact_law.apply("liggghts", tmp_path, ["materials.in"], damping=False)


def test_schema_takes_a_boolean_and_refuses_anything_else(tmp_path: Path) -> None:
    config = yaml.safe_load(CI.read_text())
    for value, ok in ((False, True), ("off", False)):
        config["material"]["tangential_damping"] = value
        path = tmp_path / f"{value}.yaml"
        path.write_text(yaml.safe_dump(config))
        proc = subprocess.run([sys.executable, "-m", "pipeline.workflow", "check-config", str(path)],
                              cwd=REPO, capture_output=True, text=True, check=False)
        assert (proc.returncode == 0) == ok, proc.stderr[-1000:]
        if not ok:
            assert "tangential_damping" in proc.stderr and "Traceback" not in proc.stderr


WALL_SLIDE = """
include common_settings.in
region domain block -0.01 0.01 -0.01 0.01 -0.01 0.01 units box
create_box 4 domain
include materials.in
{wall}
create_atoms 1 single 0.0 0.0 -0.004004 units box
set atom 1 diameter 0.002 density 2500
variable dx equal 0.01*elapsed*{dt!r}
variable vx equal 0.01
variable zero equal 0.0
fix mv all move variable v_dx v_zero v_zero v_vx v_zero v_zero
dump d all custom 1 wall.dump id fx fy fz
dump_modify d format "%d %.17g %.17g %.17g"
run 1
"""


@pytest.mark.parametrize("damping", [True, False])
def test_liggghts_takes_the_rewritten_wall_line(tmp_path: Path, damping: bool) -> None:
    """A grain sliding at 1 cm/s on the pour's floor (its fix wall/gran line as copied): after one
    step the tangential force is spring plus damping with the damping on, and the spring alone,
    k_t v dt (much smaller), with it off."""
    if shutil.which("liggghts") is None:
        pytest.fail("LIGGGHTS is not installed: run scripts/install.sh (this test runs the real binary)")
    liggghts = _engines({"tangential_damping": damping})[0]
    liggghts.copy_templates("planar_shear", tmp_path)
    wall = next(line for line in (tmp_path / "fill.in").read_text().splitlines() if line.startswith("fix floor"))
    wall = wall.replace("zplane 0.0", "zplane -0.005")
    dt = 1e-6
    (tmp_path / "in.wall").write_text(WALL_SLIDE.format(wall=wall, dt=dt))
    variables = {"skin": 2e-4, "youngs_modulus": 3.2e7, "poisson_ratio": 0.3, "restitution_matrix": [0.5] * 16,
                 "friction_matrix": [0.5] * 16, "dt": dt}
    header = "".join(f'variable {k} string "{render.format_value(v)}"\n' for k, v in variables.items())
    (tmp_path / "in.wall").write_text(header + (tmp_path / "in.wall").read_text())
    proc = subprocess.run(["liggghts", "-in", "in.wall", "-log", "log.wall"], cwd=tmp_path, capture_output=True,
                          text=True, check=False)
    assert proc.returncode == 0, proc.stdout[-2000:]
    f_x = float((tmp_path / "wall.dump").read_text().split()[-3])
    # LIGGGHTS' wall: the grain's own radius as R*, E* and G* of the same material on both sides.
    nu, E, r, delta = 0.3, 3.2e7, 0.001, 0.001 - 0.000996
    k_t = 8.0 * E / (4.0 * (2.0 - nu) * (1.0 + nu)) * (r * delta) ** 0.5
    spring = k_t * 0.01 * dt
    if damping:
        assert abs(f_x) > 5.0 * spring
    else:
        assert abs(f_x) == pytest.approx(spring, rel=1e-3)
