"""The calibration set: only the rheometer runs and the named non-local case's replicas ever reach the fits."""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
import yaml

from pipeline.calibration.calibrate import CalibrationError, check_calibration_set
from pipeline.common.config import ConfigError, calibration_runs, dem_runs, load_config, validate_config, validation_cases

REPO = Path(__file__).resolve().parents[3]
CI = REPO / "config" / "ci.yaml"


def test_validation_cases_are_every_case_without_a_calibration_run() -> None:
    config = load_config(CI)
    used = calibration_runs(config)
    assert {c for c, _ in used} == {"rheometer", "shear_gravity"}
    assert set(validation_cases(config)) == set(config["cases"]) - {"rheometer", "shear_gravity"}
    assert len(validation_cases(config)) >= 3  # two planar validation cases and the intruder


def test_a_validation_run_handed_to_the_calibration_is_refused() -> None:
    config = load_config(CI)
    with pytest.raises(CalibrationError, match="shear_gravity_heavy/r1: not in the calibration set"):
        check_calibration_set(config, [("rheometer", "I0.02-P200-r1"), ("shear_gravity_heavy", "r1")])
    with pytest.raises(CalibrationError, match="shear_gravity/L4-r1"):
        check_calibration_set(config, [("shear_gravity", "L4-r1")])  # a size-study run of the calibration case
    # Every replica of the calibration case, and only those, by default.
    assert [r for c, r in calibration_runs(config) if c == "shear_gravity"] == ["r1", "r2"]
    check_calibration_set(config, calibration_runs(config))


@pytest.mark.parametrize("case, runs, words", [("shear_gravity", ["r9"], "shear_gravity/r9 is not a replica run"),
                                               ("shear_gravity", ["L4-r1"], "nonlocal_runs"),
                                               ("shear_gravity", ["r1", "r1"], "names a run twice"),
                                               ("intruder", ["D4-r1"], "nonlocal_runs"),
                                               ("intruder", "all", "planar case with gravity"),
                                               ("rheometer", "all", "planar case with gravity"),
                                               ("no_such_case", "all", "is not a case of this config")])
def test_config_names_existing_planar_nonlocal_runs(case: str, runs: list[str] | str, words: str) -> None:
    config = yaml.safe_load(CI.read_text())
    config["calibration"].update(nonlocal_case=case, nonlocal_runs=runs)
    with pytest.raises(ConfigError, match=words):
        validate_config(config, "c.yaml")


def test_a_subset_of_replicas_may_be_named_once() -> None:
    config = yaml.safe_load(CI.read_text())
    config["calibration"]["nonlocal_runs"] = ["r2"]
    assert [r for c, r in calibration_runs(validate_config(config, "c.yaml")) if c == "shear_gravity"] == ["r2"]
    config["calibration"]["nonlocal_run"] = "r1"
    with pytest.raises(ConfigError, match="both given"):
        validate_config(config, "c.yaml")


def test_the_workflow_wires_only_the_calibration_set_into_the_calibration(tmp_path: Path) -> None:
    # The dry run lists the calibrate job's command line: every fields file on it is a calibration run.
    cmd = [sys.executable, "-m", "snakemake", "-n", "--printshellcmds", "--configfile", str(CI),
           "--config", f"output_root={tmp_path / 'r'}", "--snakefile", str(REPO / "Snakefile"), "--directory", str(REPO)]
    out = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, check=True).stdout
    line = next(s for s in out.splitlines() if "-m pipeline.calibration" in s)
    read = set(re.findall(r"fields/([a-z_]+)/([A-Za-z0-9.\-]+)\.nc", line))
    config = load_config(CI)
    assert read == set(calibration_runs(config))
    assert not {c for c, _ in read} & set(validation_cases(config))


@pytest.mark.workflow
def test_params_name_the_runs_read_and_scores_carry_the_role(reduced_results: Path) -> None:
    config = load_config(CI)
    params = json.loads((reduced_results / "calibration" / "params.json").read_text())
    assert params["calibration_runs"] == [f"{c}/{r}" for c, r in calibration_runs(config)]
    assert all(label.split("/")[0] not in validation_cases(config) for label in params["calibration_runs"])
    scores = pd.read_csv(reduced_results / "scores.csv")
    roles = scores.groupby("case")["role"].unique()
    assert list(roles["shear_gravity"]) == ["calibration"]
    for case in validation_cases(config):
        assert list(roles[case]) == ["held_out"], case
    assert set(scores.case) >= set(validation_cases(config))
    # every DEM run of a validation case exists and none was read
    assert {f"{c}/{r}" for c, r in dem_runs(config) if c in validation_cases(config)}.isdisjoint(params["calibration_runs"])
