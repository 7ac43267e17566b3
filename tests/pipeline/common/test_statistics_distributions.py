"""The distributions' functions taken from scipy.special (pipeline.common.statistics,
pipeline.dem.precision) are scipy.stats's own, value for value."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from pipeline.common.statistics import chi2_row, normal_equivalent
from pipeline.dem.precision import error_bound_factor


@pytest.mark.parametrize("dof", [1.0, 2.0, 3.7, 30.0, 1e4])
@pytest.mark.parametrize("t", [-7.5, -2.0, 0.0, 0.3, 2.0, 40.0])
def test_normal_equivalent_is_student_t_read_as_a_normal_deviate(t: float, dof: float) -> None:
    p_value = float(2.0 * stats.t.sf(abs(t), dof))
    z, p = normal_equivalent(t, dof)
    assert p == p_value
    assert z == math.copysign(float(stats.norm.isf(0.5 * p_value)), t)


def test_normal_equivalent_tends_to_t_itself_at_many_dof() -> None:
    z, _ = normal_equivalent(2.0, 1e7)
    assert z == pytest.approx(2.0, rel=1e-6)


@pytest.mark.parametrize(("total", "dof"), [(0.2, 1.0), (3.0, 2.5), (12.49, 15.0), (220.9, 15.0), (40.0, 41.3)])
def test_chi2_row_probability_is_the_chi_squared_distribution_s(total: float, dof: float) -> None:
    cdf = float(stats.chi2.cdf(total, dof))
    assert chi2_row(total, dof)["p_value"] == min(1.0, 2.0 * min(cdf, 1.0 - cdf))


@pytest.mark.parametrize("blocks", [2, 3, 4, 5, 8, 40])
def test_error_bound_factor_is_the_chi_squared_quantile_s(blocks: int) -> None:
    dof = blocks - 1
    assert error_bound_factor(blocks, 0.9) == math.sqrt(dof / float(stats.chi2.ppf(1.0 - 0.9, dof)))


def test_error_bound_factor_values_of_its_docstring() -> None:
    assert [round(error_bound_factor(b), 2) for b in (3, 4, 5, 8)] == [2.39, 1.89, 1.68, 1.42]
    assert np.isfinite(error_bound_factor(2))
