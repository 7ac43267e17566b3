"""Benchmark (issue 57, item 1): the 2D plastic intruder solves with each regularisation stage's
first Newton step factorising its Jacobian at once (``yield2d.FRESH_LU_PER_STAGE``) and GMRES's
preconditioner given its dtype, against the code it replaced (the last stage's LU reused, GMRES then
failing its 30 iterations at every stage's first step; a dtype probe, one more LU solve, per call),
side by side in one process (alternating, CPU seconds by time.process_time; never a test).

Per model and scene: a nominal solve and a warm draw, CPU seconds old and new, their ratio and the
relative change of U (the stages' tolerance is a scaled residual of 1e-6). Scenes are
``intruder_solve.py``'s (the default's bed at 3 cells per d); the draw is that benchmark's first draw
of seed 43. A change meant for the pipeline's draws is also measured on the pipeline's own job (docs/
dem_cost.md 22: a warm start that halved these scenes' draws slowed the default's by 15 %).

Run: ``nice -n 5 python benchmarks/plastic_warm_start.py [--scenes 1 5] [--repeats 2]``
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy.sparse.linalg import LinearOperator

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import intruder_solve as bench  # noqa: E402
from continuum.intruder import INTRUDER_MODELS, GridOptions  # noqa: E402
from continuum.intruder import yield2d  # noqa: E402

CELLS_PER_D = 3.0
_rng = np.random.default_rng(43)
DRAW = {k: bench.NOMINAL[k] + bench.ERRORS[k] * _rng.standard_normal() for k in bench.NOMINAL if k != "l_cosserat"}


def solve(model: str, values: dict[str, float], scene: tuple, warm: dict[str, Any] | None = None) -> tuple[Any, float]:
    """The solution and its CPU seconds."""
    t0 = time.process_time()
    solver = INTRUDER_MODELS[model].solver(bench.GEO, bench.parameters(model, values), bench.LX, bench.rod(*scene),
                                           GridOptions(cells_per_d=CELLS_PER_D))
    return solver.solve(warm), time.process_time() - t0


def _probing_operator(shape: tuple[int, int], matvec: Any, dtype: Any = None) -> LinearOperator:
    return LinearOperator(shape, matvec=matvec)  # as before: scipy probes the dtype by one solve


def set_lu(new: bool) -> None:
    yield2d.FRESH_LU_PER_STAGE = new
    yield2d.LinearOperator = LinearOperator if new else _probing_operator


def part_lu(scenes: list[int], repeats: int) -> tuple[float, float]:
    totals = {False: 0.0, True: 0.0}
    for model in ("volume_averaged", "critical_state"):
        for k in scenes:
            got: dict[bool, list] = {False: [], True: []}
            for _ in range(repeats):
                for new in (False, True):
                    set_lu(new)
                    nominal, c1 = solve(model, bench.NOMINAL, bench.SCENES[k])
                    draw, c2 = solve(model, DRAW, bench.SCENES[k], nominal.state)
                    got[new].append((c1 + c2, nominal.speed, draw.speed))
                    totals[new] += c1 + c2
            old, new_ = np.mean([g[0] for g in got[False]]), np.mean([g[0] for g in got[True]])
            # relative change of U (a rigid rod's U is 0 in both: no change)
            du = max(abs(got[True][0][i] - got[False][0][i]) / abs(got[False][0][i]) if got[False][0][i] else
                     abs(got[True][0][i]) for i in (1, 2))
            print(f"{model} scene {k}: nominal + warm draw, last stage's LU {old:6.1f} s, fresh per stage {new_:6.1f} s: "
                  f"ratio {old / new_:.3f}; |dU| / U {du:.1e}")
    set_lu(True)
    return totals[False], totals[True]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenes", nargs="+", type=int, default=[1, 5], help="indices into intruder_solve.SCENES")
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args(argv)
    old, new = part_lu(args.scenes, args.repeats)
    print(f"== CPU s old {old:.1f}, new {new:.1f}, ratio {old / new:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
