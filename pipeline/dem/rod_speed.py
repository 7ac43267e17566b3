"""The rod's creep speed over a window, with its error, and the tests on it (pipeline/dem/intruder_run.py).

Split from :mod:`pipeline.dem.intruder_run` (which re-exports every name): the statistics of a rod's
position series, apart from the runs that make it. Speeds in m/s, along +x (the push and the top wall).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from pipeline.common.statistics import integrated_autocorrelation_time

#: Blocks the measuring window is cut into for the speed's standard error.
SPEED_BLOCKS = 8


@dataclass(frozen=True)
class CreepSpeed:
    """Steady speed of the rod over a window.

    Attributes:
        speed: mean speed along +x (m/s): the displacement over the window over its duration.
        speed_err: standard error of ``speed`` (m/s), from blocks longer than the rod's bursts
            (:func:`creep_speed`).
        displacement: x(end) - x(start) over the window (m).
        duration: window length (s).
        arrested: no steady motion: ``|speed|`` within twice its error of zero, or at or below the
            rest speed the caller names (the config's ``rod_arrest_speed_over_v`` times the wall
            speed): a rule on the speed alone, so a slow rod resolved over a short window counts
            as moving (a rule on the displacement over the window made the verdict depend on the
            window's length).
        block_err, autocorrelation_err: the block error (``speed_err``) and, for the record, the
            autocorrelation-time estimate (m/s).
        correlation_samples: the integrated autocorrelation time of the rod's velocity, in samples.
    """

    speed: float
    speed_err: float
    displacement: float
    duration: float
    arrested: bool
    block_err: float = math.nan
    autocorrelation_err: float = math.nan
    correlation_samples: float = math.nan

    def as_dict(self) -> dict[str, float | bool]:
        return asdict(self)


def creep_speed(time: np.ndarray, x: np.ndarray, n_blocks: int = SPEED_BLOCKS, rest_speed: float = 0.0) -> CreepSpeed:
    """Speed (m/s) of the rod from its position ``x`` (m) at ``time`` (s), with its error.

    ``rest_speed`` (m/s, >= 0): a speed at or below which the rod is at rest whatever its error.

    The speed is the displacement over the window over its duration (the mean of block slopes,
    used before, weighs a burst by where it falls in its block: on the 2026-12-02 default run's rods
    it was 0.67-1.07 of the displacement speed). The error is the batch-means error of the
    displacement speeds of ``n_blocks`` consecutive blocks. The rod creeps in bursts: its velocity is
    correlated over 5-20 samples and anti-correlated beyond (it rattles back), so the variance of its
    displacement over a lag L, over L, peaks at L ~ 16-64 samples and falls 2-10 fold by 256; blocks
    of 200-500 samples (8 per production of 4-8 chunks) are past that peak, and their scatter is
    the error at the bursts' time scale. (The autocorrelation-time estimate ``sd(v) sqrt(2 tau / n)``,
    recorded as ``autocorrelation_err``, is 2-8 times larger: Sokal's window stops before the
    anti-correlated tail.) What no time average holds is the rod's frozen neighbourhood: replicas of
    one depth differ by more (docs/dem.md); the scores take the DEM's uncertainty from them.
    """
    time = np.asarray(time, dtype=float)
    x = np.asarray(x, dtype=float)
    if time.size < 3 * n_blocks:
        raise ValueError(f"need at least {3 * n_blocks} samples for {n_blocks} blocks, got {time.size}")
    duration = float(time[-1] - time[0])
    displacement = float(x[-1] - x[0])
    speed = displacement / duration
    edges = np.linspace(0, time.size - 1, n_blocks + 1).round().astype(int)
    blocks = np.array([(x[b] - x[a]) / (time[b] - time[a]) for a, b in zip(edges[:-1], edges[1:])])
    block_err = float(blocks.std(ddof=1) / math.sqrt(n_blocks))
    step = np.diff(time)
    # Chunks' series meet at a shared sample: a zero time step there is no velocity sample.
    velocity = np.diff(x)[step > 0] / step[step > 0]
    tau = float(integrated_autocorrelation_time(velocity[:, None])[0]) if velocity.size > 8 else math.nan
    auto_err = float(velocity.std(ddof=1) * math.sqrt(2.0 * tau / velocity.size)) if math.isfinite(tau) else math.nan
    arrested = is_arrested(speed, block_err, rest_speed)
    return CreepSpeed(speed, block_err, displacement, duration, bool(arrested), block_err, auto_err, tau)


def production_halves(time: np.ndarray, x: np.ndarray, rest_speed: float = 0.0) -> dict[str, float] | None:
    """The rod's speed (m/s) over the first and the second half (in time) of a window, each with
    its batch-means error of ``SPEED_BLOCKS`` blocks (:func:`creep_speed`).

    The halves share the rod's neighbourhood, so their difference tests the time error alone: a
    difference within the errors and replicas farther apart than their errors put the excess in
    the frozen packing around the rod, which no longer average removes (validation/creep_halves.csv).
    None when a half holds too few samples for its blocks.
    """
    time, x = np.asarray(time, dtype=float), np.asarray(x, dtype=float)
    # The halves share the middle sample, so their displacements add up to the window's.
    middle = int(np.searchsorted(time, 0.5 * (time[0] + time[-1])))
    if min(middle + 1, time.size - middle) < 3 * SPEED_BLOCKS:
        return None
    a = creep_speed(time[: middle + 1], x[: middle + 1], rest_speed=rest_speed)
    b = creep_speed(time[middle:], x[middle:], rest_speed=rest_speed)
    return {"first": a.speed, "first_err": a.speed_err, "second": b.speed, "second_err": b.speed_err,
            "blocks": SPEED_BLOCKS}


def is_arrested(speed: float, speed_err: float, rest_speed: float) -> bool:
    """The arrest rule on the speed alone (m/s): within twice its error of zero, or no faster
    than ``rest_speed``."""
    return abs(speed) <= max(2.0 * speed_err, rest_speed)


def rod_speed_settled(before: CreepSpeed | None, latest: CreepSpeed, tol: float, rest_speed: float) -> dict[str, Any]:
    """Has the rod's speed stopped changing? ``latest``: its speed over the steady-state window,
    ``before``: over as many chunks just before (None: none yet). Speeds in m/s, ``tol`` a fraction.

    Settled when ``|U_before - U| <= tol |U| + 2 sqrt(2) err(U)``, with the latest window's error
    for both (the earlier window may hold the start-up's jump, whose block scatter would excuse
    any difference), or when the rod is at rest over the window: ``|U| + 2 err(U) <= rest_speed``.
    """
    at_rest = abs(latest.speed) + 2.0 * latest.speed_err <= rest_speed
    rod: dict[str, Any] = {"speed": latest.speed, "speed_err": latest.speed_err, "at_rest": bool(at_rest)}
    if before is None:
        return rod | {"stationary": bool(at_rest)}
    allowed = tol * abs(latest.speed) + 2.0 * math.sqrt(2.0) * latest.speed_err
    return rod | {"speed_before": before.speed, "allowed": allowed,
                  "stationary": bool(at_rest or abs(before.speed - latest.speed) <= allowed)}
