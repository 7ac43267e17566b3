"""More of the bad-input catalogue: every command refuses a mistake with one clear line, and reads
what must work (other column orders, CRLF, extra columns, gzip, per-snapshot files) to the same fields.

Dumps are made here from a small static bed (tests/pipeline/coarse_graining/test_fields.py) so
the catalogue needs no DEM run.
"""
from __future__ import annotations

import gzip
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

from pipeline.common.config import ConfigError, load_config
from tests.pipeline.coarse_graining.test_fields import write_static_bed

REPO = Path(__file__).resolve().parents[2]
CI = REPO / "config" / "ci.yaml"


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", *args], cwd=REPO, capture_output=True, text=True)


def one_clear_line(proc: subprocess.CompletedProcess, *words: str) -> None:
    assert proc.returncode != 0
    assert "Traceback" not in proc.stderr, proc.stderr
    for w in words:
        assert w in proc.stderr, (w, proc.stderr)


@pytest.fixture(scope="module")
def dump(tmp_path_factory) -> Path:
    run = tmp_path_factory.mktemp("bed") / "run"
    write_static_bed(run, layers=6)
    return sorted((run / "dumps").glob("particles_*.dump"))[0]


def fields_of(path: Path, out: Path, *extra: str) -> xr.Dataset:
    proc = cli("pipeline.coarse_graining", str(path), "--out", str(out), "--dx", "0.0005", *extra)
    assert proc.returncode == 0, proc.stderr
    return xr.open_dataset(out)


def edit(dump: Path, target: Path, fn) -> Path:
    target.write_text(fn(dump.read_text()))
    return target


# ------------------------------------------------------------------------------- output paths
@pytest.mark.parametrize("stage, command", [("coarse_graining", []), ("scoring", ["scores"]), ("models", ["planar"]),
                                            ("calibration", []), ("report", []), ("dumps", [])])
def test_output_that_is_a_folder_is_refused_before_any_work(tmp_path: Path, stage: str, command: list[str]) -> None:
    proc = cli(f"pipeline.{stage}", *command, "--out", str(tmp_path))
    one_clear_line(proc, f"--out {tmp_path}: is a folder")


def test_output_whose_parent_is_a_file_is_refused(tmp_path: Path, dump: Path) -> None:
    (tmp_path / "file").write_text("x")
    proc = cli("pipeline.coarse_graining", str(dump), "--out", str(tmp_path / "file" / "f.nc"))
    one_clear_line(proc, "is a file, not a folder")


# --------------------------------------------------------------------------- numeric options
@pytest.mark.parametrize("option, value", [("--width", "0"), ("--dx", "0"), ("--width", "-1e-3"), ("--dx", "nan"),
                                           ("--blocks", "0"), ("--bins", "-4"), ("--rho-s", "inf"),
                                           ("--diameter", "0"), ("--time-step", "0"), ("--t-start", "-1"),
                                           ("--width", "abc"), ("--blocks", "2.5")])
def test_numeric_option_out_of_range_is_refused_not_defaulted(tmp_path: Path, dump: Path, option: str, value: str) -> None:
    proc = cli("pipeline.coarse_graining", str(dump), "--out", str(tmp_path / "f.nc"), option, value)
    one_clear_line(proc, f"argument {option}")
    assert not (tmp_path / "f.nc").exists()


def test_time_window_after_the_last_snapshot_names_the_option_and_the_range(tmp_path: Path, dump: Path) -> None:
    proc = cli("pipeline.coarse_graining", str(dump), "--out", str(tmp_path / "f.nc"), "--time-step", "1e-5",
               "--t-start", "1e6")
    one_clear_line(proc, "--t-start 1e+06 s is after the last snapshot", "the dumps span")


# ------------------------------------------------------------------------------------ config
@pytest.mark.parametrize("section, key, value", [("material", "friction", math.nan), ("material", "d", math.inf),
                                                 ("dem", "chunk_strain", -math.inf), ("seed", None, math.nan)])
def test_non_finite_config_values_are_named(tmp_path: Path, section: str, key: str | None, value: float) -> None:
    config = yaml.safe_load(CI.read_text())
    if key is None:
        config[section] = value
    else:
        config[section][key] = value
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(config))
    with pytest.raises(ConfigError, match=rf"{section}{'.' + key if key else ''}: .* is not a finite number"):
        load_config(path)


def test_config_error_through_snakemake_has_no_stack_frames(tmp_path: Path) -> None:
    config = yaml.safe_load(CI.read_text())
    config["cases"]["shear_gravity"]["wall_pressure"] = 700.0
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(config))
    proc = subprocess.run([sys.executable, "-m", "snakemake", "-n", "--configfile", str(path), "--config",
                           f"output_root={tmp_path / 'r'}"], cwd=REPO, capture_output=True, text=True)
    one_clear_line(proc, f"error: {path}: cases.shear_gravity: largest working pressure")
    assert 'File "' not in proc.stderr


@pytest.mark.parametrize("run, words", [("I0.02-r1", "is not a run of case 'rheometer'"),
                                        ("I0.9-P200-r1", "is not a run of case 'rheometer'")])
def test_dem_run_id_not_in_the_config_is_refused(tmp_path: Path, run: str, words: str) -> None:
    proc = cli("pipeline.dem", "--config", str(CI), "--case", "rheometer", "--run", run, "--out", str(tmp_path / "r"))
    one_clear_line(proc, words)
    assert not (tmp_path / "r").exists()


# ------------------------------------------------------------------------------------- dumps
def test_repeated_timestep_in_one_file_is_refused(tmp_path: Path, dump: Path) -> None:
    text = dump.read_text()
    first = text[:text.index("ITEM: TIMESTEP", 10)]
    bad = tmp_path / "appended.dump"
    bad.write_text(text + first)  # a restarted run appended its first snapshot again
    proc = cli("pipeline.coarse_graining", str(bad), "--out", str(tmp_path / "f.nc"))
    one_clear_line(proc, "timesteps must increase within a file")


def test_duplicated_grain_row_is_refused(tmp_path: Path, dump: Path) -> None:
    def duplicate(text: str) -> str:
        lines = text.splitlines()
        k = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
        lines.insert(k + 2, lines[k + 1])
        lines[3] = str(int(lines[3]) + 1)
        return "\n".join(lines) + "\n"
    proc = cli("pipeline.coarse_graining", str(edit(dump, tmp_path / "dup.dump", duplicate)), "--out", str(tmp_path / "f.nc"))
    one_clear_line(proc, "appears twice in one snapshot")


def test_box_of_zero_extent_is_refused(tmp_path: Path, dump: Path) -> None:
    def flatten(text: str) -> str:
        lines = text.splitlines()
        lo = lines[5].split()[0]
        lines[5] = f"{lo} {lo}"
        return "\n".join(lines) + "\n"
    proc = cli("pipeline.coarse_graining", str(edit(dump, tmp_path / "flat.dump", flatten)), "--out", str(tmp_path / "f.nc"))
    one_clear_line(proc, "the box has no extent along x")


def test_grain_far_outside_its_periodic_box_is_refused(tmp_path: Path, dump: Path) -> None:
    def move(text: str) -> str:
        lines = text.splitlines()
        k = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
        cols = lines[k].split()[2:]
        values = lines[k + 1].split()
        values[cols.index("x")] = "5.0"
        lines[k + 1] = " ".join(values)
        return "\n".join(lines) + "\n"
    proc = cli("pipeline.coarse_graining", str(edit(dump, tmp_path / "out.dump", move)), "--out", str(tmp_path / "f.nc"))
    one_clear_line(proc, "lies outside the box")


def test_file_that_is_not_gzip_though_it_starts_like_one_is_named(tmp_path: Path) -> None:
    bad = tmp_path / "bad.dump.gz"
    bad.write_bytes(b"\x1f\x8b" + b"not really gzip")
    proc = cli("pipeline.coarse_graining", str(bad), "--out", str(tmp_path / "f.nc"))
    one_clear_line(proc, "not a readable gzip file")


def test_contact_dump_of_another_run_is_refused_by_the_command(tmp_path: Path, dump: Path) -> None:
    contacts = sorted(dump.parent.glob("contacts_*.dump"))
    if not contacts:
        pytest.fail("the static bed wrote no contact dump")

    def shift(text: str) -> str:
        return text.replace("ITEM: TIMESTEP\n", "ITEM: TIMESTEP\n9")  # other timesteps
    other = edit(contacts[0], tmp_path / "other.dump", shift)
    proc = cli("pipeline.coarse_graining", str(dump), "--contacts", str(other), "--out", str(tmp_path / "f.nc"))
    one_clear_line(proc)
    assert not (tmp_path / "f.nc").exists()


# ----------------------------------------------------------------------- what must work
def test_crlf_extra_columns_other_order_gzip_and_per_snapshot_files_give_the_same_fields(tmp_path: Path, dump: Path) -> None:
    reference = fields_of(dump, tmp_path / "ref.nc")
    crlf = tmp_path / "crlf.dump"
    crlf.write_bytes(dump.read_bytes().replace(b"\n", b"\r\n"))

    def reorder(text: str) -> str:
        out, lines, k = [], text.splitlines(), 0
        while k < len(lines):
            if lines[k].startswith("ITEM: ATOMS"):
                cols = lines[k].split()[2:]
                order = list(reversed(range(len(cols))))
                out.append("ITEM: ATOMS " + " ".join(cols[i] for i in order) + " extra_a extra_b")
                n = int(lines[k - 5])
                out += [" ".join(row.split()[i] for i in order) + " 1 2" for row in lines[k + 1:k + 1 + n]]
                k += 1 + n
            else:
                out.append(lines[k])
                k += 1
        return "\n".join(out) + "\n"
    shuffled = edit(dump, tmp_path / "shuffled.dump", reorder)
    zipped = tmp_path / "z.dump.gz"
    with gzip.open(zipped, "wt") as handle:
        handle.write(dump.read_text())
    text = dump.read_text()
    starts = [i for i in range(len(text)) if text.startswith("ITEM: TIMESTEP", i)] + [len(text)]
    singles = []
    for k, (a, b) in enumerate(zip(starts[:-1], starts[1:])):
        singles.append(tmp_path / f"snap_{k:03d}.dump")
        singles[-1].write_text(text[a:b])
    variants = {"crlf": [crlf], "reordered, extra columns": [shuffled], "gzip": [zipped], "per-snapshot": singles}
    for name, files in variants.items():
        proc = cli("pipeline.coarse_graining", *map(str, files), "--out", str(tmp_path / f"{name[:4]}.nc"), "--dx", "0.0005")
        assert proc.returncode == 0, (name, proc.stderr)
        got = xr.open_dataset(tmp_path / f"{name[:4]}.nc")
        for field in ("nu", "rho", "sigma_zz", "u_x"):
            np.testing.assert_allclose(got[field].values, reference[field].values, rtol=1e-12, atol=1e-12, err_msg=name)
        got.close()


@pytest.mark.parametrize("text, words", [("seed: [1, 2\noutput_root: x\n", ":2: not valid YAML"),
                                         ("", ":1: the config file is empty"),
                                         ("- a\n- b\n", ":1: top level must be a mapping of keys, found list")])
def test_yaml_errors_name_file_and_line_before_snakemake_reads_the_config(tmp_path: Path, text: str, words: str) -> None:
    path = tmp_path / "c.yaml"
    path.write_text(text)
    proc = cli("pipeline.workflow", "check-config", str(path))
    one_clear_line(proc, f"{path}{words}")
