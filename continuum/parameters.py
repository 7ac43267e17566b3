"""Material parameters of the continuum models, as small frozen dataclasses.

Each dataclass holds one constitutive ingredient and the few functions of it that solvers need.
Dimensionless unless stated. Stresses are compressive positive (Pa).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class MuIParameters:
    """Friction law mu(I) = mu_s + (mu_2 - mu_s) / (1 + I_0 / I) (Jop, Forterre & Pouliquen 2006).

    Attributes:
        mu_s: static (quasi-static) stress ratio, the limit I -> 0.
        mu_2: limiting stress ratio as I -> infinity.
        I_0: inertial number at which mu is halfway between mu_s and mu_2.
    """

    mu_s: float
    mu_2: float
    I_0: float

    def __post_init__(self) -> None:
        if not (0.0 < self.mu_s < self.mu_2):
            raise ValueError(f"need 0 < mu_s < mu_2, got mu_s={self.mu_s}, mu_2={self.mu_2}")
        if not self.I_0 > 0.0:
            raise ValueError(f"I_0 must be positive, got {self.I_0}")

    @property
    def b(self) -> float:
        """Slope d mu / d I at I = 0, b = (mu_2 - mu_s) / I_0 (used by NGF's local fluidity)."""
        return (self.mu_2 - self.mu_s) / self.I_0

    def mu(self, inertial_number: ArrayLike) -> FloatArray:
        """Stress ratio at inertial number I >= 0 (written so that I = 0 gives mu_s exactly)."""
        i = np.asarray(inertial_number, dtype=float)
        return self.mu_s + (self.mu_2 - self.mu_s) * i / (i + self.I_0)

    def inertial_number(self, mu: ArrayLike) -> FloatArray:
        """Inverse of mu(I): I = I_0 (mu - mu_s) / (mu_2 - mu) for mu_s < mu < mu_2, 0 for mu <= mu_s.

        Raises ValueError where mu >= mu_2: no steady flow carries that stress ratio.
        """
        m = np.asarray(mu, dtype=float)
        if np.any(m >= self.mu_2):
            raise ValueError(f"stress ratio {float(np.max(m)):.6g} >= mu_2 = {self.mu_2}: outside mu(I)")
        excess = np.maximum(m - self.mu_s, 0.0)
        return self.I_0 * excess / (self.mu_2 - m)


@dataclass(frozen=True)
class SolidFractionLaw:
    """Dilatancy law nu(I) = nu_c - a I (linear, as commonly fitted to simple-shear DEM).

    Attributes:
        nu_c: solid fraction in quasi-static flow (I -> 0).
        a: dilatancy slope, -d nu / d I.
    """

    nu_c: float
    a: float

    def __post_init__(self) -> None:
        if not (0.0 < self.nu_c < 1.0):
            raise ValueError(f"nu_c must be in (0, 1), got {self.nu_c}")
        if self.a < 0.0:
            raise ValueError(f"a must be >= 0 (shear dilates), got {self.a}")

    @property
    def I_max(self) -> float:
        """Inertial number at which the linear law would give nu = 0: the law's outer limit."""
        return np.inf if self.a == 0.0 else self.nu_c / self.a

    def nu(self, inertial_number: ArrayLike) -> FloatArray:
        """Solid fraction at inertial number I."""
        return self.nu_c - self.a * np.asarray(inertial_number, dtype=float)


@dataclass(frozen=True)
class LocalMuIParameters:
    """Parameters of the local mu(I) model with the nu(I) dilatancy law."""

    mu_i: MuIParameters
    solid_fraction: SolidFractionLaw


@dataclass(frozen=True)
class NGFParameters:
    """Non-local granular fluidity (Kamrin & Koval 2012; Henann & Kamrin 2013).

    Attributes:
        mu_i: the local law; NGF uses its linearisation mu = mu_s + b I in g_loc (as Henann &
            Kamrin do), so only mu_s and b = (mu_2 - mu_s) / I_0 enter.
        A: non-local amplitude, xi = A d / sqrt(|mu - mu_s|) (0.48 for glass beads).
        nu: solid fraction used only for the weight of the layer (NGF has no dilatancy law, so
            it predicts no nu profile).
        delta_mu: floor on |mu - mu_s| in xi, so xi <= A d / sqrt(delta_mu). The equation is solved
            as A^2 d^2 g'' = |mu - mu_s| (g - g_loc), which is regular at mu = mu_s; the floor only
            keeps the linear system non-singular when mu = mu_s over the whole layer (a
            rheometer at rest). Default 1e-6: xi <= 1000 A d, far above any layer depth here.
    """

    mu_i: MuIParameters
    A: float
    nu: float = 0.6
    delta_mu: float = 1e-6

    def __post_init__(self) -> None:
        if not self.A > 0.0:
            raise ValueError(f"A must be positive, got {self.A}")
        if not (0.0 < self.nu < 1.0):
            raise ValueError(f"nu must be in (0, 1), got {self.nu}")
        if not self.delta_mu > 0.0:
            raise ValueError(f"delta_mu must be positive, got {self.delta_mu}")

    def cooperativity_length(self, mu: ArrayLike, d: float) -> FloatArray:
        """xi(mu) = A d / sqrt(max(|mu - mu_s|, delta_mu)) in m."""
        dmu = np.maximum(np.abs(np.asarray(mu, dtype=float) - self.mu_i.mu_s), self.delta_mu)
        return self.A * d / np.sqrt(dmu)


@dataclass(frozen=True)
class CriticalStateLine:
    """Critical-state pressure p_c(nu) = p_ref exp((nu - nu_ref) / kappa), i.e. the critical-state
    line nu_cs(p) = nu_ref + kappa ln(p / p_ref).

    Why this form: it is the critical-state line of soil mechanics (linear in nu against ln p),
    steep for small kappa (rigid grains: kappa of order 1e-3 - 1e-2), has two parameters that a
    weighted linear least-squares fit of the rheometer's quasi-static (nu, p) pairs determines
    (``continuum.calibration.fit_critical_state``), and is invertible in closed form, which the
    solvers use (nu_cs(p)). It needs runs at two or more pressures to fix kappa.

    Attributes:
        nu_ref: critical-state solid fraction at the reference pressure.
        kappa: slope d nu_cs / d ln p (> 0).
        p_ref: reference pressure (Pa).
    """

    nu_ref: float
    kappa: float
    p_ref: float

    def __post_init__(self) -> None:
        if not (0.0 < self.nu_ref < 1.0):
            raise ValueError(f"nu_ref must be in (0, 1), got {self.nu_ref}")
        if not (self.kappa > 0.0 and self.p_ref > 0.0):
            raise ValueError(f"kappa and p_ref must be positive, got {self.kappa}, {self.p_ref}")

    def p_c(self, nu: ArrayLike) -> FloatArray:
        """Critical-state pressure (Pa) at solid fraction nu."""
        return self.p_ref * np.exp((np.asarray(nu, dtype=float) - self.nu_ref) / self.kappa)

    def nu_cs(self, p: ArrayLike) -> FloatArray:
        """Critical-state solid fraction at pressure p (Pa)."""
        return self.nu_ref + self.kappa * np.log(np.asarray(p, dtype=float) / self.p_ref)


@dataclass(frozen=True)
class CriticalStateParameters:
    """Local critical-state plasticity (seed eqs 1-4): yield tau = p_c(nu) sin_phi Y(alpha),
    Y(alpha) = n alpha - (n - 1) alpha^(n / (n - 1)), alpha = p / p_c(nu).

    Normalisation: tau = (sigma'_ij sigma'_ji / 2)^(1/2) and the shear-rate magnitude
    gammadot = (2 D'_ij D'_ji)^(1/2), so that in simple shear tau = |sigma_xz|, gammadot = |du/dz|
    and at the critical state (alpha = 1, Y = 1) the stress ratio is mu = sin_phi.

    Attributes:
        sin_phi: sine of the critical-state friction angle (= quasi-static stress ratio).
        line: the critical-state line p_c(nu).
        n: yield-surface exponent, n > 1 with n - 1 << 1 (seed). Steady planar flow does not
            depend on n except through which plane is weakest in a non-critical initial packing.
    """

    sin_phi: float
    line: CriticalStateLine
    n: float = 1.05

    def __post_init__(self) -> None:
        if not (0.0 < self.sin_phi < 1.0):
            raise ValueError(f"sin_phi must be in (0, 1), got {self.sin_phi}")
        if not self.n > 1.0:
            raise ValueError(f"n must exceed 1, got {self.n}")

    def yield_shape(self, alpha: ArrayLike) -> FloatArray:
        """Y(alpha); 1 at alpha = 1 (critical state), falls below zero for very loose packings."""
        a = np.asarray(alpha, dtype=float)
        expo = self.n / (self.n - 1.0)
        # alpha^(n/(n-1)) overflows for loose states; beyond e^600 Y is hugely negative anyway.
        power = np.exp(np.minimum(expo * np.log(a), 600.0))
        return self.n * a - (self.n - 1.0) * power

    def strength(self, nu: ArrayLike, p: ArrayLike) -> FloatArray:
        """Shear stress (Pa) at which a plane of solid fraction nu under pressure p yields."""
        pc = self.line.p_c(nu)
        return pc * self.sin_phi * self.yield_shape(np.asarray(p, dtype=float) / pc)


@dataclass(frozen=True)
class VolumeAveragedParameters:
    """Volume-averaged non-local plasticity (seed eqs 8-11; Dsouza & Nott 2020).

    Attributes:
        critical: the local critical-state ingredients (yield surface, p_c(nu), sin_phi).
        l: averaging length (m), the coefficient in D - l^2 lap D of seed eq 10.
    """

    critical: CriticalStateParameters
    l: float

    def __post_init__(self) -> None:
        if not self.l > 0.0:
            raise ValueError(f"l must be positive, got {self.l}")


@dataclass(frozen=True)
class CosseratParameters:
    """Cosserat plasticity (Mohan, Rao & Nott 2002; seed eqs 5-6), at the critical state.

    Attributes:
        critical: sin_phi and p_c(nu) (steady flow is at alpha = 1, so nu = nu_cs(p)).
        l: material length (m) weighting the couple stress in the yield function.
        beta: weight of the antisymmetric shear stress, beta = a1 - a2 with a1 + a2 = 1 (so the
            yield function reduces to the von Mises one for a symmetric stress).
        wall_spin_ratio: chi_w in (0, 1]: at both rough walls the grain spin is chi_w times the
            vorticity (1: no relative spin; towards 0: the wall stops the grains spinning).
    """

    critical: CriticalStateParameters
    l: float
    beta: float = 1.0
    wall_spin_ratio: float = 0.5

    def __post_init__(self) -> None:
        if not self.l > 0.0:
            raise ValueError(f"l must be positive, got {self.l}")
        if not self.beta > 0.0:
            raise ValueError(f"beta must be positive, got {self.beta}")
        if not (0.0 < self.wall_spin_ratio <= 1.0):
            raise ValueError(f"wall_spin_ratio must be in (0, 1], got {self.wall_spin_ratio}")
