"""Template rendering: every variable a template reads is defined, or rendering refuses."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.dem import liggghts_render as render


def test_stage_templates_read_only_defined_variables(tmp_path: Path) -> None:
    render.copy_templates("planar_shear", tmp_path)
    for template in ("fill.in", "shear.in"):
        needed = render.variables_read(tmp_path / template)
        assert needed, f"{template} reads no variables?"
        path = render.render_stage(tmp_path, "x", template, {name: 1 for name in needed})
        text = path.read_text()
        assert text.rstrip().endswith(f"include {template}")
        for name in needed:
            assert f"variable {name} string" in text


def test_missing_variable_is_named(tmp_path: Path) -> None:
    render.copy_templates("planar_shear", tmp_path)
    needed = sorted(render.variables_read(tmp_path / "shear.in"))
    partial = {name: 1 for name in needed[1:]}
    with pytest.raises(render.TemplateError, match=needed[0]):
        render.render_stage(tmp_path, "x", "shear.in", partial)


def test_unknown_geometry() -> None:
    with pytest.raises(render.TemplateError, match="no LIGGGHTS templates"):
        render.template_files("hexagonal_bucket")


def test_values_are_written_at_full_precision() -> None:
    assert float(render.format_value(0.1 + 0.2)) == 0.1 + 0.2
    assert render.format_value([0.5, 0.5]) == "0.5 0.5"


def test_size_distribution_has_mean_d_and_stated_width() -> None:
    sizes = render.size_classes(0.002, 0.2, 5)
    assert np.mean(sizes) == pytest.approx(0.002)
    assert min(sizes) == pytest.approx(0.0016) and max(sizes) == pytest.approx(0.0024)
    text = render.grains_include(0.002, 0.2, 5, 2500.0, [10007, 10009, 10037, 10039, 10061], 10067)
    assert text.count("particletemplate/sphere") == 5
    assert "particledistribution/discrete/numberbased 10067 5" in text
