"""How much each model asks for: fields it solves, lengths it fits, what it adds over the one before.

The order is the one a researcher pays in: first the fields a solve must carry (a velocity only,
or also a fluidity or a spin field with its own boundary conditions), then the material lengths a
calibration must fix, then the constitutive parameters, then the solve's cost. The verdict's
"simplest model a scene needs" walks this order (docs/models.md, "Model complexity").
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Complexity:
    """What a model carries: ``fields`` solved for (besides the stress, which the momentum
    balance fixes in planar flow), ``lengths`` fitted, the count of constitutive ``parameters``,
    and ``adds``: what it brings over the model before it in :data:`ORDER`."""

    fields: tuple[str, ...]
    lengths: tuple[str, ...]
    parameters: int
    adds: str


#: Simplest first.
ORDER: tuple[str, ...] = ("critical_state", "local_mu_i", "volume_averaged", "ngf", "cosserat")

MODEL_COMPLEXITY: dict[str, Complexity] = {
    "critical_state": Complexity(("u_x", "nu"), (), 4,
                                 "rate-independent yield with p_c(nu) (sin_phi, nu_ref, kappa, n)"),
    "local_mu_i": Complexity(("u_x",), (), 5,
                             "a rate dependence mu(I), nu(I) (mu_s, mu_2, I_0, nu_c, a): flow where mu > mu_s, none below"),
    "volume_averaged": Complexity(("u_x", "nu"), ("l",), 5,
                                  "one internal length l: the flow rule averaged over a sphere of radius l "
                                  "(a fourth-order velocity equation, no extra field), creep below yield"),
    "ngf": Complexity(("u_x", "g"), ("A d",), 4,
                      "a fluidity field g with its own diffusion equation and wall condition; a length "
                      "xi = A d / sqrt|mu - mu_s| that grows towards yield"),
    "cosserat": Complexity(("u_x", "omega"), ("l",), 6,
                           "a particle spin field omega and couple stress, a length l and a wall spin condition"),
}


def rank(model: str) -> int:
    """Position of ``model`` in :data:`ORDER` (0 is the simplest)."""
    try:
        return ORDER.index(model)
    except ValueError:
        raise KeyError(f"unknown model {model!r}; known: {', '.join(ORDER)}") from None
