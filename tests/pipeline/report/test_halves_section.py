"""The report's production-halves section: the planar runs drawn, the rods left to their own table."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.report.build import Figures
from pipeline.report.halves_section import creep_halves_section
from tests.pipeline.scoring.test_halves_by_run import _halves


def test_section_draws_the_planar_runs_only_and_is_empty_without_them(tmp_path: Path, rng: np.random.Generator) -> None:
    (tmp_path / "validation").mkdir()
    rod = pd.DataFrame({"case": ["intruder"], "run": ["D5-r1"], "depth_over_d": [5.0], "log10_change": [0.1],
                        "log10_change_err": [0.05], "z": [2.0], "z_normal": [1.9]})
    rod.to_csv(tmp_path / "validation" / "creep_halves.csv", index=False)
    assert creep_halves_section(tmp_path, Figures(None)) == ""
    pd.concat([_halves(rng, "r1", 0.0, 10), rod]).to_csv(tmp_path / "validation" / "creep_halves.csv", index=False)
    html = creep_halves_section(tmp_path, Figures(tmp_path / "figures"))
    assert (tmp_path / "figures" / "creep_halves.png").is_file()
    assert ">r1<" in html and "D5-r1" not in html
    assert creep_halves_section(tmp_path / "nothing", Figures(None)) == ""
