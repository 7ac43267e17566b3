"""The top wall's scores (pipeline.scoring.wall_scores): the replicas' mean and its error."""
from __future__ import annotations

import math

import pytest

from pipeline.scoring.wall_scores import replica_mean


def test_replicas_give_their_mean_and_standard_error():
    mean, err, dof = replica_mean([84.0, 86.0, 85.0, 87.0], [0.5] * 4)
    assert mean == pytest.approx(85.5) and err == pytest.approx(1.2909944 / 2.0) and dof == 3


def test_one_finite_replica_keeps_its_own_stated_error():
    # the error belongs to the replica that has a value, not to the first listed
    assert replica_mean([math.nan, 2.0], [9.0, 0.5]) == (2.0, 0.5, math.inf)
    assert math.isnan(replica_mean([math.nan], [1.0])[0])
