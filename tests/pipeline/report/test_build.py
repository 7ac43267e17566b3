"""The reduced workflow ends in a self-contained report that lists every run it made."""
from __future__ import annotations

from pathlib import Path

import pytest

from pipeline.common.config import dem_runs, load_config
from pipeline.report.build import dem_cost_table

pytestmark = pytest.mark.workflow


def test_report_lists_every_run_and_embeds_its_figures(reduced_results: Path) -> None:
    html = (reduced_results / "report.html").read_text()
    config = load_config(reduced_results / "config.effective.json")
    for case, run in dem_runs(config):
        assert f"<td class=\"text\">{run}</td>" in html, (case, run)
    assert "data:image/png;base64," in html
    assert "src=\"http" not in html  # self-contained: nothing fetched
    # Every rule left a log and a benchmark.
    assert list((reduced_results / "benchmarks").rglob("*.tsv"))
    assert list((reduced_results / "logs").rglob("*.log"))


def test_report_opens_with_the_held_out_predictions(reduced_results: Path) -> None:
    html = (reduced_results / "report.html").read_text()
    # h2 headings carry ids for the contents: find them by their text
    held = html.index(">Predictions on held-out cases</h2>")
    fitted = html.index(">Fit quality on the calibration cases</h2>")
    assert held < fitted < html.index(">The decay-length law of creep</h2>")
    # the held-out tables name the validation cases, the calibration one shear_gravity
    for case in ("shear_gravity_heavy", "shear_gravity_fast", "intruder"):
        assert f"<h3>{case} (held out)</h3>" in html[held:fitted]
    assert "<h3>shear_gravity (calibration)</h3>" in html[fitted:]
    assert "held-out cases" in html  # the accuracy-against-cost chart is drawn on them


def test_snakemake_report_archive_holds_the_captioned_figures(reduced_results: Path, tmp_path: Path) -> None:
    import subprocess
    import sys
    import zipfile

    repo = Path(__file__).resolve().parents[3]
    archive = tmp_path / "report.zip"
    cmd = [sys.executable, "-m", "snakemake", "--report", str(archive), "--configfile", "config/ci.yaml",
           "--config", f"output_root={reduced_results}", "--directory", str(repo), "--snakefile", str(repo / "Snakefile")]
    proc = subprocess.run(cmd, cwd=repo, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    names = zipfile.ZipFile(archive).namelist()
    for figure in ("decay_length.png", "profiles.png", "calibration.png", "pareto.png"):
        assert any(n.endswith(figure) for n in names), (figure, names[:20])
    assert any(n.endswith("scores.csv") for n in names)


def test_report_in_a_browser_fits_the_page_and_shows_every_score(reduced_results: Path) -> None:
    from tests.pipeline.report.browser import check_report

    seen = check_report(reduced_results / "report.html", width=1400)
    assert seen["width"] >= 1300  # the window Chromium was asked for
    assert seen["overflow"] <= 0, seen  # nothing wider than the page
    assert seen["cells"] > 50 and seen["empty"] == 0, seen


def test_the_dem_bill_counts_a_shared_fill_once() -> None:
    def run(case: str, fill_steps: int) -> dict:
        return {"case": case, "particle_count": 100, "steps": 1000, "steps_by_stage": {"fill": fill_steps},
                "wall_clock_seconds": 10.0, "mpi_ranks": 2}

    runs = [run("rheometer", 0), run("rheometer", 0), run("shear_gravity", 500)]
    fill = {"case": "rheometer", "particle_count": 100, "steps_by_stage": {"fill": 400},
            "wall_seconds_by_stage": {"fill": 3.0}, "mpi_ranks": 2}
    table = dem_cost_table(runs, [fill]).set_index("case")
    # Two states' shear and production, and their one fill; the other case's own fill in its run.
    assert table.loc["rheometer", "particle-steps"] == 100 * (1000 + 1000 + 400)
    assert table.loc["rheometer", "core-seconds"] == 2 * (10.0 + 10.0 + 3.0)
    assert table.loc["shear_gravity", "particle-steps"] == 100 * 1500
    assert table.loc["all", "runs"] == 3 and table.loc["all", "shared fills"] == 1
