"""The report's creep-resolution table: the replica means and what stops them."""
from __future__ import annotations

from pathlib import Path

import pandas as pd


def test_creep_resolution_section_shows_the_replica_means_and_what_stops_them(tmp_path: Path) -> None:
    from pipeline.report.build import creep_resolution_section

    (tmp_path / "validation").mkdir()
    rows = [{"case": "heavy", "run": "r1", "decades_best": 3.0, "limited_by": ""},
            {"case": "heavy", "run": "mean of 3 replicas", "decades_best": 3.29, "slowest_over_v_best": 2.6e-4,
             "deepest_interior_over_d": 13.5, "decades_in_bed": 3.29, "limited_by": "wall margin"}]
    pd.DataFrame(rows).to_csv(tmp_path / "validation" / "creep_resolution.csv", index=False)
    html = creep_resolution_section(tmp_path)
    assert "wall margin</td>" in html and "mean of 3 replicas" in html
    assert ">r1<" not in html  # the per-run rows stay in the file
    assert creep_resolution_section(tmp_path / "nothing") == ""
