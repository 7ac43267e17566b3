"""The bad-input catalogue, the kinds that got through until issue 32: errors met while the Snakefile
is read, targets of runs the config does not have, config files given to Snakemake directly, a
contact dump of another run with the same ids and steps, a dump with no grains, a nan in a column
nothing reads, a step killed before its side file, a state named twice; and those of issue 46: a run
target after the config of ``scripts/run_workflow.sh`` (built, or refused when not a run of the
config), a contact dump of another time of the same run, a killed coarse-graining's temporaries.
Each gets one line naming the file, key, option or run, a non-zero exit, no stack frames, and
nothing left behind."""
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
    one_clear_line(proc, str(other), "put a grain elsewhere than the particle dump", "not of this run")
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


# -------------------------------------------------------------- issue 46: three more that got through
def error_lines(proc: subprocess.CompletedProcess) -> list[str]:
    return [line for line in proc.stderr.splitlines() if line.startswith("error:")]


def run_workflow(*args: str) -> subprocess.CompletedProcess:
    """The README's workflow command (it runs scripts/install.sh first: a no-op once installed)."""
    return subprocess.run(["bash", str(REPO / "scripts" / "run_workflow.sh"), *args], cwd=REPO, capture_output=True,
                          text=True)


def test_a_run_target_after_the_config_of_the_workflow_command_is_built(tmp_path: Path) -> None:
    """``run_workflow.sh CONFIG TARGET``: the target reaches Snakemake as a target (a dry run plans
    that run's jobs and no other), not as a second config file (a FileNotFoundError traceback)."""
    path = config_file(tmp_path, lambda c: None)
    target = tmp_path / "results" / "dem" / "rheometer" / "I0.2-P200-r1" / "run.json"
    proc = run_workflow(str(path), str(target), "--dry-run")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr and "FileNotFoundError" not in proc.stderr
    assert f"Missing output files: {target}" in proc.stdout
    # Snakemake's "Job stats" table: rule, count; then "total".
    table = proc.stdout.split("Job stats:")[1].splitlines()[3:]
    planned = {line.split()[0] for line in table[:next(k for k, line in enumerate(table) if line.startswith("total"))]}
    assert planned == {"dem", "dem_fill"}, planned  # this run and its shared fill, not the whole workflow
    assert not target.exists()


def test_a_target_after_the_config_that_is_not_a_run_of_it_is_named(tmp_path: Path) -> None:
    path = config_file(tmp_path, lambda c: None)
    target = tmp_path / "results" / "dem" / "rheometer" / "I0.09-P600-r1" / "run.json"
    proc = run_workflow(str(path), str(target), "--dry-run")
    one_clear_line(proc, "error: target run rheometer/I0.09-P600-r1: not a run of this config (runs of rheometer: ")
    assert len(error_lines(proc)) == 1
    assert not target.parent.exists()


def test_a_target_given_to_the_projects_snakemake_after_configfile_is_named(tmp_path: Path) -> None:
    """``--configfile C TARGET`` reads TARGET as a config file: the wrapper says so in one line."""
    path = config_file(tmp_path, lambda c: None)
    target = tmp_path / "results" / "dem" / "rheometer" / "I0.2-P200-r1" / "run.json"
    proc = snakemake("--configfile", str(path), str(target), wrapper=True)
    one_clear_line(proc, f"error: {target}: read as a config file", f"--configfile={path}")
    assert len(proc.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "results").exists()


def creeping(source: Path, target: Path, drift: float) -> Path:
    """The static bed's dump (particles or contacts) with every grain moved along x by ``drift``
    times its height over the bed's top per snapshot: a creeping bed, the top grains moving a
    hundredth of a radius between snapshots (a contact's grains where the particle dump puts them)."""
    lines, out, snap, columns = source.read_text().splitlines(), [], -1, None
    box = next(k for k, line in enumerate(lines) if line.startswith("ITEM: BOX BOUNDS"))
    top = float(lines[box + 3].split()[1])
    for line in lines:
        if line == "ITEM: TIMESTEP":
            snap += 1
        if line.startswith("ITEM: ATOMS") or line.startswith("ITEM: ENTRIES"):
            columns = line.split()[2:]
            out.append(line)
            continue
        if line.startswith("ITEM") or columns is None or len(line.split()) != len(columns):
            out.append(line)
            continue
        words = line.split()
        # particles: x at 2, z at 4; contacts (c_pgl[1..16]): x1 0, z1 2, x2 3, z2 5, cx 13, cz 15
        pairs = [(2, 4)] if columns[0] == "id" else [(0, 2), (3, 5), (13, 15)]
        for x, z in pairs:
            words[x] = repr(float(words[x]) + drift * snap * float(words[z]) / top)
        out.append(" ".join(words))
    target.write_text("\n".join(out) + "\n")
    return target


def relabelled(source: Path, target: Path) -> Path:
    """Each contact snapshot after the first replaced by the one before it, under its own timestep:
    the contacts of one time summed on the positions of the next, as two chunks' files mixed up."""
    text = source.read_text()
    blocks = ["ITEM: TIMESTEP" + b for b in text.split("ITEM: TIMESTEP")[1:]]
    steps = [b.splitlines()[1] for b in blocks]
    moved = [blocks[0]] + [b.replace(f"ITEM: TIMESTEP\n{old}\n", f"ITEM: TIMESTEP\n{new}\n", 1)
                           for b, old, new in zip(blocks[:-1], steps[:-1], steps[1:])]
    target.write_text("".join(moved))
    return target


def test_a_contact_dump_of_another_time_of_the_same_run_is_refused(tmp_path: Path, bed: Path) -> None:
    """Every contact's two grains against the particle dump at that step. No grain moves more than a
    hundredth of its radius between two snapshots: the check of the first grain of 200 contacts
    of three snapshots, 5 % allowed past a twentieth of a radius, accepted this pair."""
    radius = 0.001
    particles = creeping(sorted(bed.glob("particles_*.dump"))[0], tmp_path / "particles.dump", 0.01 * radius)
    contacts = creeping(sorted(bed.glob("contacts_*.dump"))[0], tmp_path / "contacts.dump", 0.01 * radius)
    out = tmp_path / "out" / "fields.nc"
    proc = coarse_grain(str(particles), "--contacts", str(contacts), "--out", str(out))
    assert proc.returncode == 0, proc.stderr  # the pair as written: accepted
    out.unlink()
    other = relabelled(contacts, tmp_path / "contacts_relabelled.dump")
    proc = coarse_grain(str(particles), "--contacts", str(other), "--out", str(out))
    one_clear_line(proc, f"error: {other}: at step 2000 ", "contacts put a grain elsewhere than the particle dump "
                   f"({particles}) does at that step", "not of this run at this step")
    assert len(proc.stderr.strip().splitlines()) == 1
    assert sorted(p.name for p in out.parent.iterdir()) == []


KILLED_WRITER = """
import os, signal, sys
import pyvista, xarray
from pipeline.coarse_graining import dumps_cli
where = sys.argv[1]
target = pyvista.StructuredGrid if where == "vts" else xarray.Dataset
method = "save" if where == "vts" else "to_netcdf"
write = getattr(target, method)
def write_then_die(self, *args, **kwargs):
    write(self, *args, **kwargs)
    os.kill(os.getpid(), signal.SIGKILL)  # kill -9 with the temporary written, before its rename
setattr(target, method, write_then_die)
dumps_cli.main(sys.argv[2:])
"""


@pytest.mark.parametrize("where, rerun_plane", [("vts", True), ("vts", False), ("netcdf", True)])
def test_a_rerun_after_a_killed_coarse_graining_leaves_no_temporary_of_it(tmp_path: Path, bed: Path, where: str,
                                                                          rerun_plane: bool) -> None:
    """kill -9 while the x-z fields (or the NetCDF) are written leaves a temporary; the command
    again, x-z or profile, removes it, saying so in one line, and leaves only its own outputs (and
    the user's other files, their names alike)."""
    particles = sorted(bed.glob("particles_*.dump"))[0]
    folder = tmp_path / "out"
    folder.mkdir()
    mine = [folder / "notes.tmp.txt", folder / ".other.tmp.vts", folder / "other.nc.tmp", folder / ".fields.tmp.nc"]
    for path in mine:
        path.write_text("the user's")
    plane = ["--plane", "xz", "--dx", "0.001"]
    command = [str(particles), "--out", str(folder / "fields.nc")]
    killed = subprocess.run([sys.executable, "-c", KILLED_WRITER, where, *command, *plane], cwd=REPO,
                            capture_output=True, text=True)
    assert killed.returncode == -9, killed.stderr
    left = sorted(p.name for p in folder.iterdir() if p not in mine)
    temporaries = [name for name in left if "tmp" in name]
    assert temporaries and "fields.nc" not in left, left
    proc = coarse_grain(*command, *(plane if rerun_plane else ["--dx", "0.001"]))
    assert proc.returncode == 0, proc.stderr
    notes = [line for line in proc.stderr.splitlines() if line.startswith("note: removed")]
    assert len(notes) == 1 and all(str(folder / name) in notes[0] for name in temporaries), proc.stderr
    print("message:", notes[0])
    outputs = ["fields.nc", "fields.vts"] if rerun_plane else ["fields.nc"]
    assert sorted(p.name for p in folder.iterdir() if p not in mine) == outputs
    assert all(path.read_text() == "the user's" for path in mine)
