"""``intruder_speed``: each model's steady rod speed in the shear_gravity scene."""
from __future__ import annotations

import time
from typing import Any

from .. import solve as solve_planar
from ..errors import OutOfRangeError
from ..geometry import PlanarShear
from ..parameters import CriticalStateParameters, LocalMuIParameters, NGFParameters, VolumeAveragedParameters
from .local import kinematic_speed, layer_sliding_speed, rod_in_static_zone, yield_force
from .ngf2d import solve_2d
from .scene import GridOptions, IntruderSpeed, RodIntruder

# models with a prediction, and how it is obtained (cosserat: see docs/intruder.md)
INTRUDER_MODELS: dict[str, str] = {
    "ngf": "2d",
    "local_mu_i": "layer_sliding",
    "critical_state": "yield_check",
    "volume_averaged": "kinematic",
}


def intruder_speed(model: str, geometry: PlanarShear, params: Any, intruder: RodIntruder,
                   cell_length_x: float, grid: GridOptions = GridOptions(), coupling: str = "frozen",
                   planar_options: dict | None = None, case: str | None = None) -> IntruderSpeed:
    """Steady speed U (m s-1, along +x) of a rod under force F (N m-1, along +x) held at height
    z_i in the periodic planar shear cell of period ``cell_length_x`` (m).

    - ``ngf``: 2D solve (``coupling`` "frozen": far-field fluidity, U = U_drift + F / K;
      "coupled": the 2D fluidity equation too). Fields returned.
    - ``local_mu_i``: the rod smeared into a layer of the 1D profile (``layer_sliding_speed``):
      U = 0 in the static zone below the layer-sliding force, the speed of the layer it slides
      above it; OutOfRangeError above the bearing (ploughing) estimate.
    - ``critical_state``: U = 0 if the rod lies in the 1D static zone and F < the yield-force
      estimate (``yield_force``), else OutOfRangeError (no 2D plastic solve).
    - ``volume_averaged``: below the yield force the rod is carried by the creep (U independent
      of F, the disc average of the 1D u_x); OutOfRangeError above it.
    - ``cosserat``: NotImplementedError (not solved in 2D; see docs/intruder.md).

    ``planar_options`` go to ``continuum.solve`` (e.g. ``nu_initial``, ``n_grid``).
    """
    t0 = time.perf_counter()
    intruder.check_inside(geometry, cell_length_x)
    opts = dict(planar_options or {})
    if model == "ngf":
        if not isinstance(params, NGFParameters):
            raise TypeError(f"ngf needs NGFParameters, got {type(params).__name__}")
        out = solve_2d(geometry, params, cell_length_x, intruder, grid, case=case, coupling=coupling)
        attrs = {k: out[k] for k in ("tau_top", "vertical_force", "torque") if k in out}
        attrs.update({k: out[k] for k in ("mu_max", "p_min", "fluidity_floor", "floor_at_rod") if k in out})
        attrs["coupling"] = out["coupling"]
        attrs["nx"], attrs["nz"] = out["fields"].attrs["nx"], out["fields"].attrs["nz"]
        return IntruderSpeed(model, out["speed"], out["converged"], out["iterations"], out["residual"],
                             out["solve_seconds"], out["n_grid"], "2d", out["drift_speed"], out["mobility"],
                             planar_solve_seconds=out["planar_solve_seconds"], fields=out["fields"], attrs=attrs)
    if model in ("local_mu_i", "critical_state", "volume_averaged"):
        expected = {"local_mu_i": LocalMuIParameters, "critical_state": CriticalStateParameters,
                    "volume_averaged": VolumeAveragedParameters}[model]
        if not isinstance(params, expected):
            raise TypeError(f"{model} needs {expected.__name__}, got {type(params).__name__}")
        t1 = time.perf_counter()
        planar = solve_planar(model, geometry, params, **opts)
        planar_seconds = time.perf_counter() - t1
        sin_phi = {"local_mu_i": lambda q: q.mu_i.mu_s, "critical_state": lambda q: q.sin_phi,
                   "volume_averaged": lambda q: q.critical.sin_phi}[model](params)
        yf = yield_force(planar, sin_phi, intruder, cell_length_x)
        if model == "local_mu_i" and intruder.force_per_length < yf.bearing:
            # Rate-dependent: below the bearing failure the rod moves with the layer it slides (or
            # with the 1D flow it sits in, or not at all in the static zone below F_l).
            speed, tau_top = layer_sliding_speed(planar, params.mu_i, geometry, intruder, cell_length_x, case)
            attrs = {"yield_force_bearing": yf.bearing, "yield_force_layer": yf.layer_sliding,
                     "tau_top": tau_top, "tau_top_without_rod": float(planar.attrs["tau"])}
            if intruder.force_per_length >= yf.layer_sliding:
                method = "layer_sliding"
            else:
                method = "1d_flow" if speed > 0.0 else "yield_check"  # carried by the 1D flow, or at rest
            return IntruderSpeed(model, speed, True, 0, 0.0, time.perf_counter() - t0, int(planar.sizes["z"]), method,
                                 yield_force=yf.value,
                                 planar_solve_seconds=planar_seconds, attrs=attrs)
        if intruder.force_per_length >= yf.value:
            raise OutOfRangeError(model, f"F = {intruder.force_per_length:.3g} N/m is above the yield-force "
                                  f"estimate {yf.value:.3g} N/m: the rod fails; no 2D plastic solve here", case)
        attrs = {"yield_force_bearing": yf.bearing, "yield_force_layer": yf.layer_sliding,
                 "tau_top": float(planar.attrs["tau"])}
        if model == "volume_averaged":
            if "u_x" not in planar:
                raise OutOfRangeError(model, "planar velocity undetermined (tied yielding planes)", case)
            speed, method = kinematic_speed(planar, intruder), "kinematic"
        else:
            if "u_x" in planar and not rod_in_static_zone(planar, intruder):
                raise OutOfRangeError(model, "the rod reaches the flowing layer of the 1D solution; "
                                      "the local models are not solved in 2D", case)
            speed, method = 0.0, "yield_check"
        return IntruderSpeed(model, speed, True, 0, 0.0, time.perf_counter() - t0, 0, method,
                             drift_speed=speed, mobility=0.0, yield_force=yf.value,
                             planar_solve_seconds=planar_seconds, attrs=attrs)
    if model == "cosserat":
        raise NotImplementedError("cosserat is not solved in 2D (spin and couple-stress fields with a "
                                  "2D yield-surface solver): see docs/intruder.md")
    raise KeyError(f"unknown model {model!r}")
