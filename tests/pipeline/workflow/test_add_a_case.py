"""The README's "Add a case" example works as written: a case of the user's own name."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import yaml

from pipeline.common.config import load_config, validation_cases

REPO = Path(__file__).resolve().parents[3]


def readme_case() -> dict:
    text = (REPO / "README.md").read_text()
    block = re.search(r"<!-- add-a-case -->\s*```yaml\n(.*?)```", text, re.S).group(1)
    return yaml.safe_load(block)


def test_readme_case_validates_and_enters_the_workflow(tmp_path: Path) -> None:
    config = yaml.safe_load((REPO / "config" / "ci.yaml").read_text())
    case = readme_case()
    assert list(case) == ["loose_top"]
    config["cases"].update(case)
    config["output_root"] = str(tmp_path / "results")
    path = tmp_path / "my.yaml"
    path.write_text(yaml.safe_dump(config))
    assert "loose_top" in validation_cases(load_config(path))
    cmd = [sys.executable, "-m", "snakemake", "-n", "--configfile", str(path), "--snakefile", str(REPO / "Snakefile"),
           "--directory", str(REPO)]
    out = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    for run in ("r1", "r2"):
        assert f"dem/loose_top/{run}/run.json" in out.stdout
    assert "models/loose_top/ngf.nc" in out.stdout


def test_a_case_name_the_wildcards_cannot_carry_is_refused(tmp_path: Path) -> None:
    config = yaml.safe_load((REPO / "config" / "ci.yaml").read_text())
    config["cases"]["Loose-Top2"] = readme_case()["loose_top"]
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(config))
    out = subprocess.run([sys.executable, "-m", "pipeline.dem", "--config", str(path), "--case", "Loose-Top2",
                          "--run", "r1"], cwd=REPO, capture_output=True, text=True)
    assert out.returncode == 1 and "cases: 'Loose-Top2' does not match" in out.stderr and "Traceback" not in out.stderr
