"""The intruder's production target ``rod_min_travel_over_d`` (issue 55): a moving rod's resolved
speed stops the production only once the rod has travelled that many grain diameters; a rod at rest
needs no travel, and a control is never asked for one. No LIGGGHTS: the rule is tested on its own."""
from __future__ import annotations

from typing import Any

import pytest

from pipeline.dem.intruder_run import CreepSpeed, IntruderRun

D = 0.002
V = 0.1
PRECISION = {"rod_speed_rel": 0.25, "rod_arrest_speed_over_v": 1e-5, "rod_min_travel_over_d": 1.0}


def judged(speed: float, speed_err: float, displacement_over_d: float, control: bool = False,
           precision: dict[str, Any] = PRECISION) -> dict[str, Any]:
    """The production test of a run whose rod crept ``displacement_over_d`` d at ``speed`` (m/s)."""
    run = IntruderRun.__new__(IntruderRun)  # the rule only, no run folder
    run.control = control
    run.mat = {"d": D}
    run.reference_speed = lambda: V  # type: ignore[method-assign]
    creep = CreepSpeed(speed=speed, speed_err=speed_err, displacement=displacement_over_d * D,
                       duration=displacement_over_d * D / speed if speed else 1.0, arrested=False)
    run.rod_creep = lambda t0, t1: creep  # type: ignore[method-assign]
    return run.production_precision([{"t_start": 0.0, "t_end": 1.0}], precision)


def test_a_resolved_speed_waits_for_a_grain_of_travel() -> None:
    short = judged(1e-3, 1e-5, 0.5)
    assert short["met"]["rod_speed_rel"] and not short["met"]["rod_min_travel_over_d"]
    assert not short["all_met"]
    far = judged(1e-3, 1e-5, 1.2)
    assert far["all_met"] and far["reached"]["rod_min_travel_over_d"] == pytest.approx(1.2)


def test_travel_alone_does_not_stop_an_unresolved_speed() -> None:
    # 2 d travelled with a relative error of 0.5: the speed target decides.
    out = judged(1e-3, 5e-4, 2.0)
    assert out["met"]["rod_min_travel_over_d"] and not out["met"]["rod_speed_rel"] and not out["all_met"]


def test_a_rod_at_rest_needs_no_travel() -> None:
    out = judged(1e-8, 1e-9, 1e-5)
    assert out["met"]["rod_arrest_speed_over_v"] and out["all_met"]


def test_a_control_is_not_asked_to_travel() -> None:
    out = judged(1e-3, 1e-5, 0.1, control=True)
    assert "rod_min_travel_over_d" not in out["met"] and out["all_met"]


def test_without_the_target_the_rule_is_as_before() -> None:
    plain = {k: v for k, v in PRECISION.items() if k != "rod_min_travel_over_d"}
    out = judged(1e-3, 1e-5, 0.1, precision=plain)
    assert out["all_met"] and "rod_min_travel_over_d" not in out["met"]


def test_the_log_line_of_a_rod_held_still_to_the_last_digit() -> None:
    """A weak push with the wall at rest can leave the rod exactly where it was: nothing is allowed
    and nothing changed, which the steady test's log line reads as 0 of allowed (it divided by 0)."""
    run = IntruderRun.__new__(IntruderRun)
    test = {"force": {"drift": 0.0, "allowed": 1.0}, "height": {"drift": 0.0, "allowed": 1.0}, "load": {"ratio": 1.0},
            "rod": {"speed": 0.0, "speed_err": 0.0, "at_rest": True, "speed_before": 0.0, "allowed": 0.0,
                    "stationary": True}}
    assert run._steady_summary(test).endswith("0.00 of allowed")
    test["rod"]["speed_before"] = 1e-6
    assert run._steady_summary(test).endswith("inf of allowed")
