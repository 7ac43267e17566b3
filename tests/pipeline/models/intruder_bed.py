"""A small intruder bed for the intruder stage's tests: calibration, runs and fields of a 12 d bed."""
from __future__ import annotations

import xarray as xr

D = 0.002
MU = {"mu_s": 0.374, "mu_2": 1.023, "I_0": 0.637, "nu_c": 0.587, "a": 0.141}
PARAMS = {"local": {k: {"value": v} for k, v in MU.items()}, "critical_state": {},
          "nonlocal": {"ngf": {"A": {"value": 0.327}}}, "normal_stresses": {"sigma_zz_over_p": {"value": 1.058}},
          "wall": {"slip_length": {"value": 0.0, "error": 0.0}}}


def run(name: str, depth: float, force: float, sweep: bool = False, push: float = 0.5) -> dict:
    rod = {"depth": depth * D, "diameter": 3 * D, "force": force * 4 * D, "length": 4 * D, "depth_over_d": depth,
           "depth_target_over_d": depth, "control": False, "force_sweep": sweep, "push_over_yield": push}
    return {"case": "intruder", "run": name, "cell": [8 * D, 4 * D], "intruder": rod}


def fields() -> xr.Dataset:
    return xr.Dataset(attrs={"z_bottom_contact_plane": 0.0, "z_top_contact_plane": 12 * D, "z_top_wall": 12.5 * D,
                             "wall_speed": 0.1, "wall_pressure": 200.0, "gravity": 9.81, "d": D, "rho_s": 2500.0})
