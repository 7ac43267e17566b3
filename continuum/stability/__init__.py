"""Linear (Hadamard) stability of the continuum models about homogeneous simple shear.

Every model is linearised about steady simple shear at inertial number ``I`` and perturbed by
plane waves ``exp(i k.x + s t)``, ``k = |k| (cos theta, sin theta)`` in the (flow x, gradient z)
plane; the growth rate is ``max Re(s)`` over the modes. Units: growth rates in units of the base
shear rate ``gammadot0`` (so ``s / gammadot0``), wavenumbers as ``K = |k| d``. The physical ``d``,
``rho_s`` and ``p`` drop out: the dimensionless problem depends on them only through ``I``.
A state is well posed when the growth rate stays bounded as K grows (``base.is_well_posed``).
The algebra is in ``docs/stability.md``.

Parameter dictionaries (``parameter_sets`` values) use the names of ``calibration/params.json``:
``mu_s, mu_2, I_0, A, nu_c, a, sin_phi`` and the averaging / Cosserat length either as ``l_over_d``
or as ``l`` and ``d`` (m). Missing keys fall back to ``GLASS_BEADS_REFERENCE``, except
``sin_phi`` which defaults to the set's own ``mu_s`` (the critical-state friction).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np
import pandas as pd

from continuum.stability import base, cosserat, critical_state, mu_i, ngf

MODELS = ("local_mu_i", "critical_state", "cosserat", "ngf", "volume_averaged")

#: the glass-bead reference set; the non-local lengths and critical-state constants are choices
#: of this module (documented in docs/stability.md), not fitted values
GLASS_BEADS_REFERENCE: dict[str, float] = {
    "mu_s": 0.3819, "mu_2": 0.6435, "I_0": 0.279, "A": 0.48, "nu_c": 0.6, "a": 0.3,
    "sin_phi": 0.3819, "l_over_d": 2.0, "n_exp": critical_state.DEFAULT_N,
    "pc_log_slope": critical_state.DEFAULT_PC_LOG_SLOPE, "a_skew": 0.25, "mu_b": 0.0,
}

#: wavenumbers K = |k| d sampled for the classification and for max_growth_rate
K_VALUES = base.DEFAULT_K
THETA_VALUES = base.DEFAULT_THETA


def _full(params: Mapping[str, float]) -> dict[str, float]:
    out = dict(GLASS_BEADS_REFERENCE)
    out["sin_phi"] = float(params.get("mu_s", out["mu_s"]))
    out.update({k: float(v) for k, v in params.items() if isinstance(v, (int, float))})
    if "l" in params and "d" in params and "l_over_d" not in params:
        out["l_over_d"] = float(params["l"]) / float(params["d"])
    return out


# -- one function per model: max Re(s) / gammadot0 over the modes, shape (len(K), len(theta)) --

def local_mu_i_growth(
    I: float, mu_s: float, mu_2: float, I_0: float, nu_c: float = 0.6, a: float = 0.3,
    compressible: bool = False, mu_b: float = 0.0,
    K: np.ndarray = K_VALUES, theta: np.ndarray = THETA_VALUES,
) -> np.ndarray:
    """Growth rate Re(s)/gammadot0 of local mu(I) vs (K, theta); incompressible by default.

    ``compressible=True`` uses ``nu = nu_c - a I`` (mass conservation, p = p(nu, gammadot)) and
    an optional bulk friction ``mu_b``; the incompressible case uses ``nu_c - a I`` only as the
    bulk density (clipped at nu_c / 2 where the line would go below that).
    """
    if compressible:
        s = mu_i.compressible_growth(I, mu_s, mu_2, I_0, nu_c, a, mu_b, K=K, theta=theta)
    else:
        nu = max(nu_c - a * I, 0.5 * nu_c)
        s = mu_i.incompressible_growth(I, mu_s, mu_2, I_0, nu=nu, K=K, theta=theta)
    return np.max(s.real, axis=-1)


def critical_state_growth(
    I: float, sin_phi: float, nu_c: float, n_exp: float = critical_state.DEFAULT_N,
    pc_log_slope: float = critical_state.DEFAULT_PC_LOG_SLOPE,
    K: np.ndarray = K_VALUES, theta: np.ndarray = THETA_VALUES,
) -> np.ndarray:
    """Growth rate Re(s)/gammadot0 of critical-state plasticity (seed eqs 1-4) vs (K, theta)."""
    s = critical_state.growth(I, sin_phi, nu_c, 0.0, n_exp, pc_log_slope, K=K, theta=theta)
    return np.max(s.real, axis=-1)


def volume_averaged_growth(
    I: float, sin_phi: float, nu_c: float, l_over_d: float,
    n_exp: float = critical_state.DEFAULT_N,
    pc_log_slope: float = critical_state.DEFAULT_PC_LOG_SLOPE,
    K: np.ndarray = K_VALUES, theta: np.ndarray = THETA_VALUES,
) -> np.ndarray:
    """Growth rate Re(s)/gammadot0 of the volume-averaged model (seed eqs 10-11) vs (K, theta)."""
    s = critical_state.growth(I, sin_phi, nu_c, l_over_d, n_exp, pc_log_slope, K=K, theta=theta)
    return np.max(s.real, axis=-1)


def cosserat_growth(
    I: float, sin_phi: float, nu_c: float, l_over_d: float, a_skew: float = 0.25,
    spin_inertia: float = 0.1, n_exp: float = critical_state.DEFAULT_N,
    pc_log_slope: float = critical_state.DEFAULT_PC_LOG_SLOPE,
    K: np.ndarray = K_VALUES, theta: np.ndarray = THETA_VALUES,
) -> np.ndarray:
    """Growth rate Re(s)/gammadot0 of Cosserat plasticity (Mohan et al. 2002) vs (K, theta)."""
    s = cosserat.growth(I, sin_phi, nu_c, l_over_d, a_skew, spin_inertia, n_exp, pc_log_slope,
                        K=K, theta=theta)
    return np.max(s.real, axis=-1)


def ngf_growth(
    I: float, mu_s: float, mu_2: float, I_0: float, A: float, nu_c: float = 0.6,
    K: np.ndarray = K_VALUES, theta: np.ndarray = THETA_VALUES,
) -> np.ndarray:
    """Growth rate Re(s)/gammadot0 of non-local granular fluidity vs (K, theta)."""
    s = ngf.growth(I, mu_s, mu_2, I_0, A, nu=nu_c, K=K, theta=theta)
    return np.max(s.real, axis=-1)


def _eigs(model: str, I: float, p: dict[str, float], variant: str, K, theta) -> np.ndarray:
    if model == "local_mu_i":
        if variant == "compressible":
            return mu_i.compressible_growth(I, p["mu_s"], p["mu_2"], p["I_0"], p["nu_c"], p["a"],
                                            p["mu_b"], K=K, theta=theta)
        nu = max(p["nu_c"] - p["a"] * I, 0.5 * p["nu_c"])
        return mu_i.incompressible_growth(I, p["mu_s"], p["mu_2"], p["I_0"], nu=nu, K=K, theta=theta)
    if model == "critical_state":
        if variant == "incompressible":
            # rate-independent Coulomb limit: incompressible mu(I) with a constant mu = sin(phi)
            return mu_i.incompressible_growth(I, p["sin_phi"], p["sin_phi"], 1.0, nu=p["nu_c"],
                                              K=K, theta=theta)
        return critical_state.growth(I, p["sin_phi"], p["nu_c"], 0.0, p["n_exp"],
                                     p["pc_log_slope"], K=K, theta=theta)
    if model == "volume_averaged":
        return critical_state.growth(I, p["sin_phi"], p["nu_c"], p["l_over_d"], p["n_exp"],
                                     p["pc_log_slope"], K=K, theta=theta)
    if model == "cosserat":
        return cosserat.growth(I, p["sin_phi"], p["nu_c"], p["l_over_d"], p["a_skew"], 0.1,
                               p["n_exp"], p["pc_log_slope"], K=K, theta=theta)
    if model == "ngf":
        return ngf.growth(I, p["mu_s"], p["mu_2"], p["I_0"], p["A"], nu=p["nu_c"], K=K, theta=theta)
    raise ValueError(f"unknown model {model!r}; expected one of {MODELS}")


def state_mu(model: str, I: float, params: Mapping[str, float]) -> float:
    """Stress ratio mu of the homogeneous base state of ``model`` at inertial number I."""
    p = _full(params)
    if model == "local_mu_i":
        return float(mu_i.mu_of_I(I, p["mu_s"], p["mu_2"], p["I_0"]))
    if model == "ngf":
        return ngf.base_mu(I, p["mu_s"], p["mu_2"], p["I_0"])
    if model in ("critical_state", "volume_averaged", "cosserat"):
        return p["sin_phi"]
    raise ValueError(f"unknown model {model!r}; expected one of {MODELS}")


@dataclass(frozen=True)
class StateResult:
    """Classification of one state: base mu, max growth rate (units of gammadot0), well posed."""

    mu: float
    max_growth_rate: float
    well_posed: bool


def classify(
    model: str, I: float, params: Mapping[str, float], variant: str = "",
    K: np.ndarray = K_VALUES, theta: np.ndarray = THETA_VALUES,
) -> StateResult:
    """Hadamard classification of ``model`` at inertial number I.

    ``max_growth_rate`` is max Re(s)/gammadot0 over orientations, modes and the sampled
    K = |k| d <= K.max() (1e6 by default): for an ill-posed state it grows with K.max() and
    only its sign and size relative to the well-posed states mean anything.
    ``variant``: "" (default law), "compressible" (local_mu_i), "incompressible"
    (critical_state, the rigid-plastic Coulomb limit).
    """
    p = _full(params)
    s = _eigs(model, I, p, variant, K, theta)
    G = base.max_growth(s)
    scale = np.max(np.abs(s), axis=(-1, -2))
    ok = base.is_well_posed(K, G, scale) and not _pressure_degenerate(model, I, p, variant)
    return StateResult(state_mu(model, I, p), float(G.max()), ok)


def _pressure_degenerate(model: str, I: float, p: dict[str, float], variant: str) -> bool:
    """Incompressible laws whose pressure equation loses its coefficient at some orientation.

    The normal momentum balance fixes the pressure perturbation through ``1 - m cos 2 theta'``
    (theta' from the stretching axis, docs/stability.md); once ``m >= 1`` it vanishes along a
    direction and the growth rate has a pole there, unbounded over wavevectors of finite |k| that
    a sampled theta grid only brushes. m = mu (1 - c/2) for mu(I), mu for NGF (where numerically
    the poles appear exactly from mu = 1) and sin(phi) for the Coulomb limit.
    """
    if model == "ngf":
        return ngf.base_mu(I, p["mu_s"], p["mu_2"], p["I_0"]) >= 1.0
    if model == "local_mu_i" and variant != "compressible":
        mu = float(mu_i.mu_of_I(I, p["mu_s"], p["mu_2"], p["I_0"]))
        c = I * (p["mu_2"] - p["mu_s"]) * p["I_0"] / (I + p["I_0"]) ** 2 / mu
        return mu * (1.0 - c / 2.0) >= 1.0
    if model == "critical_state" and variant == "incompressible":
        return p["sin_phi"] >= 1.0
    return False


def well_posed(model: str, I: float, params: Mapping[str, float], variant: str = "") -> bool:
    """True when ``model`` about simple shear at inertial number I has bounded growth in K."""
    return classify(model, I, params, variant).well_posed


#: extra row sets written by ``well_posedness_table``: (model, variant, parameter_set suffix)
VARIANTS = (("local_mu_i", "compressible", "+compressible"),
            ("critical_state", "incompressible", "+incompressible"))


def well_posedness_table(
    parameter_sets: Mapping[str, Mapping[str, float]], I_values: np.ndarray | list[float],
    include_variants: bool = True,
) -> pd.DataFrame:
    """One row per model, parameter set and inertial number, with the contract columns.

    Columns ``model, parameter_set, I, mu, max_growth_rate, well_posed``; ``max_growth_rate``
    is dimensionless (units of gammadot0, see ``classify``). With ``include_variants`` the
    compressible mu(I)-nu(I) law is reported as model ``local_mu_i`` under parameter set
    ``<name>+compressible`` and the incompressible Coulomb limit of critical-state plasticity as
    ``critical_state`` under ``<name>+incompressible``. States where ``nu_c - a I <= 0`` (the
    compressible law has no solid fraction there) are left out.
    """
    rows = []
    runs = [(m, "", "") for m in MODELS]
    if include_variants:
        runs += list(VARIANTS)
    for name, params in parameter_sets.items():
        p = _full(params)
        for model, variant, suffix in runs:
            for I in np.asarray(I_values, float):
                if variant == "compressible" and not p["nu_c"] - p["a"] * I > 0.0:
                    continue
                r = classify(model, float(I), p, variant)
                rows.append({"model": model, "parameter_set": name + suffix, "I": float(I),
                             "mu": r.mu, "max_growth_rate": r.max_growth_rate,
                             "well_posed": bool(r.well_posed)})
    return pd.DataFrame(rows, columns=["model", "parameter_set", "I", "mu", "max_growth_rate",
                                       "well_posed"])


@dataclass(frozen=True)
class StabilityMap:
    """Growth and classification resolved in inertial number and wavevector orientation.

    Attributes:
        model, variant: as in ``classify``.
        I: inertial numbers (nI,); mu: base stress ratio at each I (nI,).
        theta: wavevector angle from the flow direction x (rad) (nt,).
        growth: max Re(s)/gammadot0 over modes at K = k_ref (nI, nt).
        well_posed: per-orientation classification, growth bounded in K along that
            direction (nI, nt); a state is well posed when the whole row is.
        k_ref: the K = |k| d at which ``growth`` is evaluated.
    """

    model: str
    variant: str
    I: np.ndarray
    mu: np.ndarray
    theta: np.ndarray
    growth: np.ndarray
    well_posed: np.ndarray
    k_ref: float


def stability_map(
    model: str, params: Mapping[str, float], I_values: np.ndarray | list[float],
    theta: np.ndarray = THETA_VALUES, k_ref: float = 1e3, variant: str = "",
) -> StabilityMap:
    """2D map (I x orientation) of growth rate and well-posedness, for the report's plot."""
    p = _full(params)
    I_arr = np.asarray(I_values, float)
    K = np.unique(np.concatenate([K_VALUES, [k_ref]]))
    iref = int(np.searchsorted(K, k_ref))
    growth = np.empty((I_arr.size, np.size(theta)))
    ok = np.empty_like(growth, dtype=bool)
    for i, I in enumerate(I_arr):
        s = _eigs(model, float(I), p, variant, K, theta)
        Gt = np.max(s.real, axis=-1)  # (nk, nt)
        scale = np.max(np.abs(s), axis=-1)
        growth[i] = Gt[iref]
        ok[i] = [base.is_well_posed(K, Gt[:, j], scale[:, j]) for j in range(Gt.shape[1])]
    mu = np.array([state_mu(model, float(I), p) for I in I_arr])
    return StabilityMap(model, variant, I_arr, mu, np.asarray(theta, float), growth, ok, k_ref)
