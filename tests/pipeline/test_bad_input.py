"""Bad-input catalogue: every stage refuses bad input loudly, naming the file, line or parameter,
and leaves no output that looks complete (outputs are written under a temporary name and renamed).

Kinds: truncated dump, missing column, renamed column, NaN, infinite value, empty steady window,
contact dump of other timesteps, contact dump naming absent grains, malformed wall series,
run.json and fields file of another format version, LIGGGHTS missing, LIGGGHTS exiting non-zero,
lost grains, kinetic-energy blow-up, overlap above the bound, config key of the wrong type, config
key out of range, a continuum solver that does not converge.

The LIGGGHTS failures use a fake ``liggghts`` script put first on PATH: they test the runner's
error path, not physics (the real failures are in test_failure_catalogue.py).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

from pipeline.dem import cli as dem_command
from pipeline.dem import planar_run as dem_run
from pipeline.dumps import store as dump_store
from pipeline.coarse_graining import fields
from pipeline.common import formats
from pipeline.models import planar as solve_models
from pipeline.common.config import ConfigError, load_config
from pipeline.dem.liggghts_log import DEMRunError
from tests.pipeline.stability.test_failure_catalogue import reference_params
from tests.pipeline.coarse_graining.test_fields import write_static_bed

REPO = Path(__file__).resolve().parents[2]
CI = REPO / "config" / "ci.yaml"


# ------------------------------------------------------------------------------------ helpers
def assert_nothing_left(folder: Path) -> None:
    """No output file, complete-looking or temporary, in the stage's output folder."""
    left = sorted(p.name for p in folder.rglob("*")) if folder.exists() else []
    assert left == [], f"output left behind after a failure: {left}"


def edit_lines(path: Path, change: Callable[[list[str]], list[str]]) -> None:
    path.write_text("\n".join(change(path.read_text().splitlines())) + "\n")


def set_word(line: str, column: int, value: str) -> str:
    words = line.split()
    words[column] = value
    return " ".join(words)


def drop_column(lines: list[str], name: str) -> list[str]:
    """Remove one column (header and every data row) from a particle dump."""
    out, k = [], None
    for line in lines:
        if line.startswith("ITEM: ATOMS"):
            words = line.split()
            k = words.index(name) - 2
            out.append(" ".join(w for w in words if w != name))
        elif k is not None and not line.startswith("ITEM") and len(line.split()) > 3:
            out.append(" ".join(w for j, w in enumerate(line.split()) if j != k))
        else:
            out.append(line)
    return out


def rename_column(lines: list[str], old: str, new: str) -> list[str]:
    return [" ".join(new if w == old else w for w in line.split()) if line.startswith("ITEM: ATOMS") else line
            for line in lines]


def run_fields_cli(run_dir: Path, out_dir: Path, capsys: pytest.CaptureFixture[str]) -> str:
    """The fields workflow step on ``run_dir``; it must fail. Returns its error message."""
    code = fields.main(["--config", str(CI), "--run-dir", str(run_dir), "--out", str(out_dir / "r.nc")])
    err = capsys.readouterr().err
    assert code == 1, err
    assert_nothing_left(out_dir)
    return err


@pytest.fixture
def bed(tmp_path: Path) -> Path:
    """A valid synthetic run folder (static bed: exact answers, see test_fields.py)."""
    run_dir = tmp_path / "run"
    write_static_bed(run_dir)
    return run_dir


# The particle dump of the static bed: 8 snapshots of 256 grains, 9 header lines each.
P = "dumps/particles_000.dump"
C = "dumps/contacts_000.dump"
ROWS = 256
SNAPSHOT_LINES = 9 + ROWS
FIRST_ROW = 10  # 1-based line of the first atom row


# ------------------------------------------------------------------------------------ dumps
def test_truncated_dump_is_named_and_the_store_is_not_written(bed: Path, tmp_path: Path, capsys) -> None:
    keep = SNAPSHOT_LINES + 9 + 20  # the second snapshot keeps 20 of its rows
    edit_lines(bed / P, lambda lines: lines[:keep])
    out = tmp_path / "store"
    out.mkdir()
    assert dump_store.main([str(bed), "--out", str(out / "dumps.nc")]) == 1
    err = capsys.readouterr().err
    assert f"{P}:{keep + 1}: snapshot at step 2000 ends after 20 of {ROWS} lines (truncated file?)" in err
    assert_nothing_left(out)


def test_truncated_mid_line_names_the_line(bed: Path, tmp_path: Path, capsys) -> None:
    text = (bed / P).read_text()
    cut = text.index("\n", len(text) // 3) + 12  # 11 characters into a data line
    (bed / P).write_text(text[:cut])
    line = text[:cut].count("\n") + 1
    err = run_fields_cli(bed, tmp_path / "out", capsys)
    assert f"{P}:{line}: too few columns" in err


@pytest.mark.parametrize("where", ["end", "middle"])
def test_dump_cut_between_snapshots_is_caught_by_the_run_record(bed: Path, tmp_path: Path, capsys, where: str) -> None:
    """A cut exactly between snapshots parses cleanly: run.json's dump_every tells snapshots are missing."""
    run = json.loads((bed / "run.json").read_text())
    (bed / "run.json").write_text(json.dumps(run | {"dump_every": 1000}))
    if where == "end":
        edit_lines(bed / P, lambda lines: lines[: 5 * SNAPSHOT_LINES])
        words = "the last snapshot (step 5000) is more than dump_every = 1000 steps before the end of run.json steady_state_window"
    else:
        edit_lines(bed / P, lambda lines: lines[: 2 * SNAPSHOT_LINES] + lines[4 * SNAPSHOT_LINES:])
        words = "no snapshot between steps 2000 and 5000 (run.json dump_every = 1000)"
    err = run_fields_cli(bed, tmp_path / "out", capsys)
    assert f"{P}: {words}" in err


@pytest.mark.parametrize("column", ["mass", "vx"])
def test_missing_column_is_named(bed: Path, tmp_path: Path, capsys, column: str) -> None:
    edit_lines(bed / P, lambda lines: drop_column(lines, column))
    err = run_fields_cli(bed, tmp_path / "out", capsys)
    assert f"{P}:9: missing column(s) {column}" in err


def test_renamed_column_is_named_with_the_header(bed: Path, tmp_path: Path, capsys) -> None:
    edit_lines(bed / P, lambda lines: rename_column(lines, "vz", "velz"))
    err = run_fields_cli(bed, tmp_path / "out", capsys)
    assert "missing column(s) vz" in err and "velz" in err and P in err


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf", "NaN"])
def test_non_finite_value_names_the_line(bed: Path, tmp_path: Path, capsys, bad: str) -> None:
    line = FIRST_ROW + 5
    edit_lines(bed / P, lambda lines: lines[: line - 1] + [set_word(lines[line - 1], 4, bad)] + lines[line:])
    err = run_fields_cli(bed, tmp_path / "out", capsys)
    assert f"{P}:{line}:" in err and "non-finite" in err


# ------------------------------------------------------------------------- run-level inputs
def test_empty_steady_window_names_the_run_json_key(bed: Path, tmp_path: Path, capsys) -> None:
    run = json.loads((bed / "run.json").read_text())
    run["steady_state_window"] = [1.0, 2.0]  # after the last dump
    (bed / "run.json").write_text(json.dumps(run))
    err = run_fields_cli(bed, tmp_path / "out", capsys)
    assert "steady_state_window [1.0, 2.0]" in err and str(bed) in err


def test_contact_dump_of_other_timesteps(bed: Path, tmp_path: Path, capsys) -> None:
    # Every contact snapshot one step later than its particle snapshot.
    edit_lines(bed / C, lambda lines: [str(int(l) + 1) if i and lines[i - 1] == "ITEM: TIMESTEP" else l
                                       for i, l in enumerate(lines)])
    err = run_fields_cli(bed, tmp_path / "out", capsys)
    assert "no contact snapshot at step(s) [1000" in err and C in err


def test_contact_dump_naming_absent_grains(bed: Path, tmp_path: Path, capsys) -> None:
    # A contact dump of another run: its grain ids run beyond this run's 64 grains.
    line = FIRST_ROW + 3
    edit_lines(bed / C, lambda lines: lines[: line - 1] + [set_word(lines[line - 1], 6, "9001")] + lines[line:])
    err = run_fields_cli(bed, tmp_path / "out", capsys)
    assert "[9001] absent from the particle dump" in err and C in err and P in err


def test_malformed_wall_series_names_file_and_line(bed: Path, tmp_path: Path, capsys) -> None:
    series = bed / "series" / "production_000.txt"
    edit_lines(series, lambda lines: lines[:5] + [" ".join(lines[5].split()[:-2])] + lines[6:])
    err = run_fields_cli(bed, tmp_path / "out", capsys)
    assert "series/production_000.txt:6: expected 9 columns, found 7" in err


def test_wall_series_with_text_in_place_of_a_number(bed: Path, tmp_path: Path, capsys) -> None:
    series = bed / "series" / "production_000.txt"
    edit_lines(series, lambda lines: lines[:3] + [set_word(lines[3], 4, "-1.#IND")] + lines[4:])
    err = run_fields_cli(bed, tmp_path / "out", capsys)
    assert "series/production_000.txt:4: not a number" in err


# ----------------------------------------------------------------- results of another version
def test_run_json_of_another_format_version_is_refused(bed: Path, tmp_path: Path, capsys) -> None:
    run = json.loads((bed / "run.json").read_text())
    for version, words in ((0, "format_version 0, this pipeline reads version 1 (written by an older"),
                           (2, "format_version 2, this pipeline reads version 1 (written by a newer")):
        (bed / "run.json").write_text(json.dumps(run | {"format_version": version}))
        err = run_fields_cli(bed, tmp_path / "out", capsys)
        assert f"{bed / 'run.json'}: run.json has {words}" in err and "rerun the DEM stage" in err


def test_unversioned_run_json_missing_keys_is_refused(bed: Path, tmp_path: Path, capsys) -> None:
    run = json.loads((bed / "run.json").read_text())
    del run["contact_columns"]  # the layout before contact columns were recorded
    (bed / "run.json").write_text(json.dumps(run))
    err = run_fields_cli(bed, tmp_path / "out", capsys)
    assert "run.json without format_version, from an older pipeline: lacks contact_columns" in err


def test_current_run_json_is_accepted_and_fields_carry_their_version(bed: Path, tmp_path: Path) -> None:
    run = json.loads((bed / "run.json").read_text())
    (bed / "run.json").write_text(json.dumps(run | {"format_version": formats.RUN_FORMAT_VERSION}))
    out = tmp_path / "out" / "r.nc"
    assert fields.main(["--config", str(CI), "--run-dir", str(bed), "--out", str(out)]) == 0
    with xr.open_dataset(out) as ds:
        assert ds.attrs["format_version"] == formats.FIELDS_FORMAT_VERSION
    assert sorted(p.name for p in out.parent.iterdir()) == ["r.nc"]


def write_params(path: Path, cosserat_l_over_d: float = 2.0) -> Path:
    params = reference_params()
    params["nonlocal"]["cosserat"]["l"]["value"] = cosserat_l_over_d * params["d"]
    path.write_text(json.dumps(params))
    return path


def fields_file(path: Path, version: int | None = formats.FIELDS_FORMAT_VERSION, depth: float = 0.03) -> Path:
    """A minimal fields file of a shear_gravity cell (the attributes the models read)."""
    z = np.linspace(0.0, depth, 31)
    ds = xr.Dataset({name: ("z", np.ones_like(z)) for name in formats.FIELDS_REQUIRED_VARS}, coords={"z": z})
    ds.attrs.update(d=0.002, rho_s=2500.0, z_bottom_wall=0.0, z_top_wall=depth, z_bottom_contact_plane=0.0,
                    z_top_contact_plane=depth, wall_speed=0.1, wall_pressure=200.0, gravity=9.81)
    if version is not None:
        ds.attrs["format_version"] = version
    ds.to_netcdf(path)
    return path


def solve_cli(tmp_path: Path, params: Path, fields_nc: Path, model: str, n_grid: int,
              capsys: pytest.CaptureFixture[str]) -> str:
    config = yaml.safe_load(CI.read_text())
    config["models"]["n_grid"] = n_grid
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(config))
    out_dir = tmp_path / "models"
    code = solve_models.main(["--config", str(tmp_path / "c.yaml"), "--params", str(params), "--case", "shear_gravity",
                              "--model", model, "--fields", str(fields_nc), "--out", str(out_dir / f"{model}.nc")])
    err = capsys.readouterr().err
    assert code == 1, err
    assert_nothing_left(out_dir)
    return err


def test_fields_file_of_an_older_pipeline_is_refused(tmp_path: Path, capsys) -> None:
    old = tmp_path / "old.nc"
    fields_file(old, version=None)
    with xr.open_dataset(old) as ds:  # the layout before u_x_err was written
        ds.drop_vars("u_x_err").to_netcdf(tmp_path / "older.nc")
    err = solve_cli(tmp_path, write_params(tmp_path / "p.json"), tmp_path / "older.nc", "ngf", 200, capsys)
    assert "older.nc: fields file without format_version, from an older pipeline: lacks u_x_err" in err
    err = solve_cli(tmp_path, write_params(tmp_path / "p.json"), fields_file(tmp_path / "v0.nc", version=0),
                    "ngf", 200, capsys)
    assert "v0.nc: fields file has format_version 0" in err and "rerun the fields stage" in err


# --------------------------------------------------------------------------- continuum solver
def test_solver_that_does_not_converge_names_model_and_case(tmp_path: Path, capsys) -> None:
    # Cosserat with l = 4 d on a 1024-node grid: the Riccati iteration does not converge (see the
    # failure catalogue); the step must say so and write no model file.
    err = solve_cli(tmp_path, write_params(tmp_path / "p.json", cosserat_l_over_d=4.0),
                    fields_file(tmp_path / "f.nc"), "cosserat", 1024, capsys)
    assert err.startswith("error: model cosserat on case shear_gravity:") and "converge" in err


# ----------------------------------------------------------------------------------- config
@pytest.mark.parametrize(("section", "key", "value", "words"), [
    ("rheometer", "n_grains", "many", "cases.rheometer.n_grains: 'many' is not of type 'integer'"),
    ("dem", "mpi_ranks", 2.5, "dem.mpi_ranks: 2.5 is not of type 'integer'"),
    ("material", "dt_over_contact_time", 0.1, "material.dt_over_contact_time: 0.1 is greater than the maximum of 0.05"),
    ("material", "friction", -0.1, "material.friction: -0.1 is less than the minimum of 0"),
])
def test_bad_config_key_is_named_and_nothing_runs(tmp_path: Path, section: str, key: str, value: object,
                                                  words: str) -> None:
    config = yaml.safe_load(CI.read_text())
    (config["cases"] if section == "rheometer" else config)[section][key] = value
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(config))
    with pytest.raises(ConfigError, match="invalid configuration") as info:
        load_config(path)
    assert f"{path}: {words}" in str(info.value)


def test_bad_config_stops_the_dem_cli_cleanly(tmp_path: Path) -> None:
    config = yaml.safe_load(CI.read_text())
    config["material"]["max_overlap"] = "0.01"
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(config))
    out = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-m", "pipeline.dem", "--config", str(path), "--case", "rheometer",
                           "--run", "I0.2-P200-r1", "--out", str(out)], cwd=REPO, capture_output=True, text=True)
    assert proc.returncode == 1
    assert "material.max_overlap: '0.01' is not of type 'number'" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not out.exists()


def test_report_on_a_root_without_its_runs_names_the_missing_file(tmp_path: Path) -> None:
    config = yaml.safe_load(CI.read_text())
    config["output_root"] = str(tmp_path / "empty")
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(config))
    out = tmp_path / "report.html"
    proc = subprocess.run([sys.executable, "-m", "pipeline.report", "--config", str(path), "--out", str(out)],
                          cwd=REPO, capture_output=True, text=True)
    assert proc.returncode == 1
    assert "Traceback" not in proc.stderr
    assert proc.stderr.startswith("error: ") and "run.json" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_error_check_refuses_a_bad_creep_target_naming_it(tmp_path: Path) -> None:
    """``scoring.creep_decades`` is checked by the schema: a target of 0 decades is named in one
    line and no table is written; a missing fields file is named too."""
    config = yaml.safe_load(CI.read_text())
    config.setdefault("scoring", {})["creep_decades"] = {"calibration": 0, "held_out": 3.5}
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(config))
    out, resolution = tmp_path / "error_check.csv", tmp_path / "creep_resolution.csv"
    command = [sys.executable, "-m", "pipeline.scoring", "error-check", "--fields", str(tmp_path / "r1.nc"),
               "--out", str(out), "--resolution-out", str(resolution)]
    proc = subprocess.run([*command, "--config", str(path)], cwd=REPO, capture_output=True, text=True)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert "scoring.creep_decades.calibration" in proc.stderr
    assert not out.exists() and not resolution.exists()
    proc = subprocess.run(command, cwd=REPO, capture_output=True, text=True)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert proc.stderr.startswith("error: ") and "r1.nc" in proc.stderr
    assert not out.exists() and not resolution.exists()


# ---------------------------------------------------------------------------------- LIGGGHTS
FAKE_EXIT = """#!/bin/sh
echo "LIGGGHTS (Version LIGGGHTS-PUBLIC 3.8.0) fake"
echo "Segmentation fault (core dumped)"
exit {code}
"""

FAKE_LOST = """#!/bin/sh
# the log named by -log: LIGGGHTS writes the same error there and to the screen
log="$4"
mkdir -p "$(dirname "$log")"
printf 'Setting up run ...\\nERROR: Lost atoms: original 560 current 559 (../thermo.cpp:398)\\n' > "$log"
echo "ERROR: Lost atoms: original 560 current 559 (../thermo.cpp:398)"
exit 1
"""

# A chunk that ends normally but whose wall series shows a blow-up (ke) or soft grains (overlap).
FAKE_CHUNK = f"""#!{sys.executable}
import os, re, sys
stage_input, log = sys.argv[2], sys.argv[4]
text = open(stage_input).read()
var = dict(re.findall(r'^variable (\\S+) string "(.*)"$', text, re.M))
steps, every = int(var["chunk_steps"]), int(var["series_every"])
ke, overlap = float(os.environ["FAKE_KE"]), float(os.environ["FAKE_OVERLAP"])
with open(var["series_file"], "w") as f:
    f.write("# Time-averaged data for fix series\\n# TimeStep v_time ...\\n")
    for k in range(1, steps // every + 1):
        f.write(f"{{k * every}} {{k * every * 1e-6}} 0.01 -0.05 -0.01 0.05 0.03 {{ke}} {{overlap}}\\n")
open(var["restart_out"], "w").write("fake restart")
open(log, "w").write("Loop time of 1.0 on 1 procs for %d steps with 560 atoms\\n" % steps)
"""


@pytest.fixture
def fake_liggghts(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Callable[[str], None]:
    """Install a fake ``liggghts`` script (first on PATH) with the given text."""
    folder = tmp_path / "fakebin"
    folder.mkdir()

    def install(script: str) -> None:
        path = folder / "liggghts"
        path.write_text(script)
        path.chmod(0o755)

    monkeypatch.setenv("PATH", f"{folder}:{os.environ['PATH']}")
    return install


def dem_cli(config: Path, out: Path) -> list[str]:
    return ["--config", str(config), "--case", "rheometer", "--run", "I0.2-P200-r1", "--out", str(out),
            "--mpi-launcher", "none"]


def assert_no_stage_committed(out: Path) -> None:
    """Neither run.json nor a committed stage: a rerun starts at the failed stage."""
    assert not (out / "run.json").exists()
    state = json.loads((out / "state.json").read_text()) if (out / "state.json").exists() else {}
    assert "fill" not in state and not state.get("chunks")
    assert not list(out.glob("restart/*.restart"))


def test_missing_liggghts_binary_is_named(tmp_path: Path) -> None:
    config = yaml.safe_load(CI.read_text())
    config["dem"]["liggghts"] = "liggghts-not-installed"
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(config))
    out = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-m", "pipeline.dem", *dem_cli(path, out)], cwd=REPO,
                          capture_output=True, text=True)
    assert proc.returncode == 1
    assert "error: LIGGGHTS executable 'liggghts-not-installed' not found on PATH" in proc.stderr
    assert_no_stage_committed(out)


def test_liggghts_exiting_non_zero_is_named_with_stage_and_log(tmp_path: Path, fake_liggghts) -> None:
    fake_liggghts(FAKE_EXIT.format(code=1))
    out = tmp_path / "run"
    with pytest.raises(DEMRunError) as info:
        dem_command.main(dem_cli(CI, out))
    message = str(info.value)
    assert message.startswith("DEM run rheometer/I0.2-P200-r1 stage fill: LIGGGHTS exited with code 1")
    assert "logs/fill.log" in message and "Segmentation fault" in message
    assert_no_stage_committed(out)


def test_lost_grains_are_reported_as_such(tmp_path: Path, fake_liggghts) -> None:
    fake_liggghts(FAKE_LOST)
    out = tmp_path / "run"
    with pytest.raises(DEMRunError) as info:
        dem_command.main(dem_cli(CI, out))
    assert "stage fill: LIGGGHTS reported lost grains: ERROR: Lost atoms: original 560 current 559" in str(info.value)
    assert "logs/fill.log" in str(info.value)
    assert_no_stage_committed(out)


def settled_run(run_dir: Path) -> dem_run.PlanarShearRun:
    """A run of the reduced shear_gravity case as if its fill had finished (state only)."""
    run = dem_run.PlanarShearRun(load_config(CI), "shear_gravity", "r1", run_dir)
    run.run_dir.mkdir(parents=True)
    dem_run.render.copy_templates("planar_shear", run_dir)
    run._load_state()
    run.state["fill"] = {"settled_gap": 0.03, "z_bottom_wall": 0.0012, "z_top_wall": 0.0312, "n_top_wall_grains": 30,
                         "n_bottom_wall_grains": 30, "wall_mass": 1e-4, "wall_coverage": [0.5, 0.5]}
    run._save_state()
    return run


@pytest.mark.parametrize(("ke", "overlap", "words"), [
    (1.0, 1e-6, "stage shear_000: kinetic energy blew up"),
    (1e-6, 0.002 * 0.05, "stage shear_000: contact overlap reached 0.05 d, above the bound material.max_overlap"),
])
def test_chunk_failing_its_checks_is_not_committed(tmp_path: Path, fake_liggghts, monkeypatch, ke: float,
                                                   overlap: float, words: str) -> None:
    fake_liggghts(FAKE_CHUNK)
    monkeypatch.setenv("FAKE_KE", repr(ke))
    monkeypatch.setenv("FAKE_OVERLAP", repr(overlap))
    run = settled_run(tmp_path / "run")
    with pytest.raises(DEMRunError) as info:
        run._run_chunk("shear", 0, run._chunk_plan())
    assert str(info.value).startswith(f"DEM run shear_gravity/r1 {words}")
    if "kinetic" in words:
        assert "limit dem.max_ke_ratio = 100" in str(info.value)
    # The chunk's restart stays under its temporary name and the state lists no chunk.
    assert (tmp_path / "run" / "restart" / "shear_000.restart.tmp").exists()
    assert not (tmp_path / "run" / "restart" / "shear_000.restart").exists()
    assert json.loads((tmp_path / "run" / "state.json").read_text())["chunks"] == []
    assert not (tmp_path / "run" / "run.json").exists()


def test_fake_chunk_within_bounds_is_committed(tmp_path: Path, fake_liggghts, monkeypatch) -> None:
    """The control of the test above: the same fake chunk with sane values passes and commits."""
    fake_liggghts(FAKE_CHUNK)
    monkeypatch.setenv("FAKE_KE", "1e-6")
    monkeypatch.setenv("FAKE_OVERLAP", "1e-6")
    run = settled_run(tmp_path / "run")
    record = run._run_chunk("shear", 0, run._chunk_plan())
    assert record["restart"] == "restart/shear_000.restart"
    assert (tmp_path / "run" / "restart" / "shear_000.restart").exists()
    assert [c["stage"] for c in json.loads((tmp_path / "run" / "state.json").read_text())["chunks"]] == ["shear_000"]

