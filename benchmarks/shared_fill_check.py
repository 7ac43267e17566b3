"""Does a shared fill shift the rheometer's states together? Two roots' states side by side.

Reads ``calibration/params.json`` (``rheometer_states``: each state's bulk I, mu, nu and their
errors) of an output root whose rheometer states poured their own fills and of one whose states
share one fill per replica (``cases.rheometer.shared_fill``). Each state's residual about one
common reference curve (the first root's mu(I) and nu(I) fits) is compared between the roots, so
the small differences of the states' reached I do not enter. A realisation effect of the shared
walls and packing would move every state of the shared root alike: it shows as a mean residual
difference over the states beyond its error, while independent realisations scatter about zero
(the chi2 of the differences says whether the states' errors account for that scatter).

Usage: ``python benchmarks/shared_fill_check.py --independent /work/results-run --shared results``
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from continuum.parameters import MuIParameters, SolidFractionLaw  # noqa: E402


def states(root: Path) -> tuple[pd.DataFrame, dict]:
    """The rheometer states of a root (one row per state, keyed by its run id) and its local fit."""
    path = root / "calibration" / "params.json"
    if not path.is_file():
        raise SystemExit(f"{root}: no calibration/params.json (run the workflow's calibration first)")
    params = json.loads(path.read_text())
    rows = pd.DataFrame(params["rheometer_states"])
    rows["run"] = [Path(f).stem for f in rows["file"]]
    return rows.set_index("run"), params["local"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--independent", type=Path, required=True, help="output root whose states poured their own fills")
    parser.add_argument("--shared", type=Path, required=True, help="output root whose states share one fill per replica")
    args = parser.parse_args(argv)
    indep, local = states(args.independent)
    shared, _ = states(args.shared)
    common = indep.index.intersection(shared.index)
    if len(common) < 3:
        raise SystemExit(f"only {len(common)} rheometer states in both roots: nothing to compare")
    mu_law = MuIParameters(mu_s=local["mu_s"]["value"], mu_2=local["mu_2"]["value"], I_0=local["I_0"]["value"])
    nu_law = SolidFractionLaw(nu_c=local["nu_c"]["value"], a=local["a"]["value"])
    out = []
    for name, law in (("mu", mu_law.mu), ("nu", nu_law.nu)):
        res = {label: frame.loc[common, name] - law(frame.loc[common, "I"].to_numpy())
               for label, frame in (("independent", indep), ("shared", shared))}
        diff = res["shared"] - res["independent"]
        err = np.hypot(indep.loc[common, f"{name}_err"], shared.loc[common, f"{name}_err"])
        weights = 1.0 / err**2
        mean = float(np.sum(weights * diff) / np.sum(weights))
        mean_err = float(1.0 / np.sqrt(np.sum(weights)))
        chi2 = float(np.sum(((diff - mean) / err) ** 2) / (len(common) - 1))
        table = pd.DataFrame({"I_independent": indep.loc[common, "I"], "I_shared": shared.loc[common, "I"],
                              "residual_independent": res["independent"], "residual_shared": res["shared"],
                              "difference": diff, "error": err, "sigmas": diff / err})
        print(f"\n{name}: residual about the independent root's fit, per state")
        print(table.to_string(float_format=lambda v: f"{v:.4g}"))
        print(f"{name}: common shift (weighted mean difference, shared - independent) = {mean:+.4g} +- {mean_err:.2g} "
              f"({mean / mean_err:+.2f} sigma); scatter about it: chi2 / dof = {chi2:.2f} ({len(common) - 1} dof)")
        out.append((name, mean, mean_err))
    return 0


if __name__ == "__main__":
    sys.exit(main())
