"""Fixtures for the continuum tests: the shear_gravity-like cell and glass-bead parameters.

Values are the Henann-group NGF benchmark's (depth 20 d, top pressure 6.67 nu rho_s g d, wall
speed 1e-3 sqrt(g d); mu_s = 0.3819, mu_2 = 0.6435, I_0 = 0.279, A = 0.48) with nu = 0.6 and a
nu(I) slope a = 0.3. They are defaults for tests only: the pipeline passes calibrated values.
"""
from __future__ import annotations

import numpy as np
import pytest

from continuum.geometry import PlanarShear
from continuum.parameters import (
    CriticalStateLine,
    CriticalStateParameters,
    LocalMuIParameters,
    MuIParameters,
    NGFParameters,
    SolidFractionLaw,
)

D = 0.004
RHO_S = 2500.0
G = 9.81


def shear_gravity(wall_speed_factor: float = 1e-3, depth_d: float = 20.0, gravity: float = G) -> PlanarShear:
    return PlanarShear(depth=depth_d * D, wall_speed=wall_speed_factor * np.sqrt(G * D),
                       wall_pressure=6.67 * 0.6 * RHO_S * G * D, gravity=gravity, d=D, rho_s=RHO_S)


@pytest.fixture
def glass_mu_i() -> MuIParameters:
    return MuIParameters(mu_s=0.3819, mu_2=0.6435, I_0=0.279)


@pytest.fixture
def local_params(glass_mu_i: MuIParameters) -> LocalMuIParameters:
    return LocalMuIParameters(glass_mu_i, SolidFractionLaw(nu_c=0.6, a=0.3))


@pytest.fixture
def ngf_params(glass_mu_i: MuIParameters) -> NGFParameters:
    return NGFParameters(glass_mu_i, A=0.48, nu=0.6)


@pytest.fixture
def cs_params() -> CriticalStateParameters:
    return CriticalStateParameters(sin_phi=0.3819, line=CriticalStateLine(nu_ref=0.6, kappa=0.01, p_ref=500.0))


def observed_order(n: np.ndarray, values: np.ndarray, reference: float) -> np.ndarray:
    """Orders log2(e_k / e_{k+1}) of successive grid doublings against a much finer reference."""
    err = np.abs(np.asarray(values) - reference)
    return np.log(err[:-1] / err[1:]) / np.log(np.asarray(n[1:]) / np.asarray(n[:-1]))
