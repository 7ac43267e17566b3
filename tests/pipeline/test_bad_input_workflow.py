"""The bad-input catalogue, the kinds that got through until issue 32: errors met while the Snakefile
is read, targets of runs the config does not have, config files given to Snakemake directly, a
contact dump of another run with the same ids and steps, a dump with no grains, a nan in a column
nothing reads, a step killed before its side file, a state named twice. Each gets one line naming
the file, key, option or run, a non-zero exit, no stack frames, and nothing left behind."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from pipeline.common.config import ConfigError, validate_config
from tests.pipeline.coarse_graining.test_fields import write_static_bed

REPO = Path(__file__).resolve().parents[2]
CI = REPO / "config" / "ci.yaml"


def snakemake(*args: str, wrapper: bool = False) -> subprocess.CompletedProcess:
    cmd = ["bash", str(REPO / "scripts" / "snakemake.sh")] if wrapper else [sys.executable, "-m", "snakemake"]
    return subprocess.run([*cmd, "-n", *args], cwd=REPO, capture_output=True, text=True)


def one_clear_line(proc: subprocess.CompletedProcess, *words: str) -> None:
    assert proc.returncode != 0, proc.stdout[-2000:]
    assert "Traceback" not in proc.stderr and 'File "' not in proc.stderr, proc.stderr[-3000:]
    print("message:", proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else "")  # shown by pytest -s
    for w in words:
        assert w in proc.stderr, (w, proc.stderr[-3000:])


def config_file(tmp_path: Path, edit) -> Path:
    config = yaml.safe_load(CI.read_text())
    config["output_root"] = str(tmp_path / "results")
    edit(config)
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


# ----------------------------------------------------------------- while the Snakefile is read
@pytest.mark.parametrize("case, geometry, words", [
    ("rheometer", "intruder", "cases.rheometer.geometry: 'planar_shear' was expected"),
    ("shear_gravity", "intruder", "cases.shear_gravity.geometry: 'planar_shear' was expected"),
    ("intruder", "planar_shear", "cases.intruder.geometry: 'intruder' was expected"),
])
def test_a_case_whose_geometry_does_not_fit_its_keys_is_named(tmp_path: Path, case: str, geometry: str,
                                                              words: str) -> None:
    path = config_file(tmp_path, lambda c: c["cases"][case].update(geometry=geometry))
    one_clear_line(snakemake("--configfile", str(path)), str(path), words)
    assert not (tmp_path / "results").exists()


def test_an_output_root_that_is_a_file_is_named(tmp_path: Path) -> None:
    blocker = tmp_path / "blocker"
    blocker.write_text("not a folder")
    path = config_file(tmp_path, lambda c: c.update(output_root=str(blocker)))
    one_clear_line(snakemake("--configfile", str(path)), f"output_root = {blocker}: an existing file, not a folder")
    assert blocker.read_text() == "not a folder"


def test_an_output_root_under_a_place_that_takes_no_folder_is_named(tmp_path: Path) -> None:
    # /proc refuses new folders to every user, root included.
    path = config_file(tmp_path, lambda c: c.update(output_root="/proc/granular-validate-results"))
    one_clear_line(snakemake("--configfile", str(path)), "output_root = /proc/granular-validate-results: cannot be created")


@pytest.mark.parametrize("text, words", [("seed: [1, 2\noutput_root: x\n", ":2: not valid YAML"),
                                         ("", ":1: the config file is empty")])
def test_yaml_errors_given_to_the_projects_snakemake_name_file_and_line(tmp_path: Path, text: str, words: str) -> None:
    path = tmp_path / "c.yaml"
    path.write_text(text)
    one_clear_line(snakemake("--configfile", str(path), wrapper=True), f"{path}{words}")


# -------------------------------------------------------------------------------- run targets
@pytest.mark.parametrize("target, words", [
    ("dem/rheometer/I0.09-P600-r1/run.json", "target run rheometer/I0.09-P600-r1: not a run of this config (runs of "
     "rheometer: I0.02-P200-r1"),
    ("dem/rheometer/I0.02-P200-r7/run.json", "target run rheometer/I0.02-P200-r7: not a run of this config"),
    ("fields/no_case/r1.nc", "target run no_case/r1: the config has no case 'no_case'"),
    ("dem/rheometer/fill-r9/fill.json", "target fill rheometer/fill-r9: 'fill-r9' is not a shared fill"),
])
def test_a_target_run_the_config_does_not_have_is_named(tmp_path: Path, target: str, words: str) -> None:
    root = tmp_path / "results"
    # The target first: after --config Snakemake reads every word as a config entry.
    proc = snakemake(str(root / target), "--configfile", str(CI), "--config", f"output_root={root}")
    one_clear_line(proc, words)
    assert not (root / target).parent.exists()


# ------------------------------------------------------------------------------------ configs
def test_a_state_named_twice_is_refused() -> None:
    config = yaml.safe_load(CI.read_text())
    config["cases"]["rheometer"]["extra_states"].append({"inertial_number": 0.02, "wall_pressure": 200.0})
    with pytest.raises(ConfigError, match="cases.rheometer: inertial_numbers / extra_states name the state of run "
                                          "I0.02-P200-r1 twice"):
        validate_config(config, "c.yaml")


# -------------------------------------------------------------------------- standalone dumps
@pytest.fixture(scope="module")
def bed(tmp_path_factory) -> Path:
    run = tmp_path_factory.mktemp("bed") / "run"
    write_static_bed(run, layers=6)
    return run / "dumps"


def coarse_grain(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pipeline.coarse_graining", *args], cwd=REPO, capture_output=True,
                          text=True)


def test_a_contact_dump_of_another_run_with_the_same_ids_and_steps_is_refused(tmp_path: Path, bed: Path) -> None:
    """Ids and steps alone do not prove the pairing: positions at the same step do."""
    particles = sorted(bed.glob("particles_*.dump"))[0]
    contacts = sorted(bed.glob("contacts_*.dump"))[0]
    lines = contacts.read_text().splitlines()
    body = [k for k, line in enumerate(lines) if line.startswith("ITEM: ENTRIES")]
    moved = list(lines)
    for start in body:  # every contact's first grain a third of a grain away: another packing
        k = start + 1
        while k < len(moved) and not moved[k].startswith("ITEM"):
            words = moved[k].split()
            words[0] = repr(float(words[0]) + 0.0007)
            moved[k] = " ".join(words)
            k += 1
    other = tmp_path / "other_contacts.dump"
    other.write_text("\n".join(moved) + "\n")
    out = tmp_path / "f.nc"
    proc = coarse_grain(str(particles), "--contacts", str(other), "--out", str(out))
    one_clear_line(proc, str(other), "sits elsewhere than in the particle dump", "not of this run")
    assert not out.exists()


def test_a_dump_with_no_grains_is_named(tmp_path: Path) -> None:
    empty = tmp_path / "empty.dump"
    empty.write_text("ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n0\nITEM: BOX BOUNDS pp pp ff\n0 1\n0 1\n0 1\n"
                     "ITEM: ATOMS id type x y z vx vy vz radius mass\n")
    out = tmp_path / "f.nc"
    one_clear_line(coarse_grain(str(empty), "--out", str(out)), f"{empty}: 1 snapshot(s) and not one grain")
    assert not out.exists()


def test_a_nan_in_a_column_nothing_reads_is_accepted_and_one_in_a_read_column_named(tmp_path: Path, bed: Path) -> None:
    particles = sorted(bed.glob("particles_*.dump"))[0]
    lines = particles.read_text().splitlines()
    header = next(k for k, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    extra = [line + " extra" if k == header else (line + " nan" if k > header and not line.startswith("ITEM")
                                                  and k < header + 5 else line + " 1.0" if k > header and not
                                                  line.startswith("ITEM") and len(line.split()) > 3 else line)
             for k, line in enumerate(lines)]
    # Only the first snapshot has the extra column: keep that one.
    end = next((k for k in range(header + 1, len(extra)) if extra[k].startswith("ITEM: TIMESTEP")), len(extra))
    tolerated = tmp_path / "extra.dump"
    tolerated.write_text("\n".join(extra[:end]) + "\n")
    out = tmp_path / "ok.nc"
    proc = coarse_grain(str(tolerated), "--out", str(out), "--dx", "0.0005")
    assert proc.returncode == 0, proc.stderr
    assert out.exists()
    # The same nan in vx (a column the velocity is made of) is refused with its line.
    vx = lines[header].split()[2:].index("vx")
    bad = list(lines[:end])
    words = bad[header + 2].split()
    words[vx] = "nan"
    bad[header + 2] = " ".join(words)
    refused = tmp_path / "bad.dump"
    refused.write_text("\n".join(bad) + "\n")
    one_clear_line(coarse_grain(str(refused), "--out", str(tmp_path / "bad.nc")),
                   f"{refused}:{header + 3}: non-finite value nan in column vx")
    assert not (tmp_path / "bad.nc").exists()


def test_a_failed_step_leaves_no_side_file_of_an_earlier_one(tmp_path: Path, bed: Path) -> None:
    """A .vts beside the main file from an earlier invocation is gone when a step fails (or is
    killed) before writing its own: nothing that looks complete is left."""
    particles = sorted(bed.glob("particles_*.dump"))[0]
    out = tmp_path / "f.nc"
    proc = coarse_grain(str(particles), "--plane", "xz", "--dx", "0.001", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert out.with_suffix(".vts").exists()
    out.unlink()
    # Refused after the options are read (a time window after the last snapshot).
    proc = coarse_grain(str(particles), "--plane", "xz", "--t-start", "1e9", "--time-step", "1e-6", "--out", str(out))
    assert proc.returncode != 0
    assert not out.exists() and not out.with_suffix(".vts").exists()
