"""The reduced workflow ends in a self-contained report that lists every run it made."""
from __future__ import annotations

from pathlib import Path

import pytest

from pipeline.common.config import dem_runs, load_config

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
