"""Cross-check of the two DEM engines: the same config run by LIGGGHTS and by LAMMPS, side by side.

``python benchmarks/engine_crosscheck.py ROOT_A ROOT_B [--csv OUT]``: two output roots of the
workflow whose configs differ only in ``dem.engine`` (and ``output_root``; any other difference is
printed first). Compared, each with its error:

- every rheometer state: the bulk ``mu``, ``nu`` and ``I`` (:func:`pipeline.calibration.calibrate.bulk_state`,
  ``calibration.bulk_margin_over_d`` from the walls), the mean over the state's replicas with the
  larger of their combined errors and their scatter over sqrt(n);
- every planar case with gravity: ``log10(u / V)`` of the replica mean (:func:`pipeline.common.observables.replica_mean`)
  at whole d below the top contact plane, where both roots resolve it above 2 errors; the decades
  resolved (``validation/creep_resolution.csv``, no error); the calibrated local laws (mu_s, mu_2,
  I_0, nu_c, a of ``calibration/params.json``, or for a root without a calibration the same fits
  on its rheometer fields: the states as curves); the same creep **at equal mu / mu_s**
  (issue 56, item 5: each bed's own replica-mean mu(z) = tau / p over its root's calibrated mu_s, at
  ``MU_RATIO_LEVELS``; the error adds mu's replica scatter and mu_s's calibration error, through the
  profile's local slope, to u's); the creep law's ``beta``
  (``validation/decay_length_fit.csv``, the DEM on all windows); the non-local lengths
  (``calibration/params.json``).

The test: for each quantity with errors on both sides ``z = (b - a) / sqrt(err_a^2 + err_b^2)``; per
group ``chi2 = sum z^2`` with as many degrees of freedom as terms, and its p-value (the engines
agree at 5 % where p > 0.05). Profile points 1 d apart share the coarse-graining kernel and the
packing's frozen structure, so they are not independent: the profile also enters thinned to every
third depth (3 d apart, about the kernel's support). The verdict is the chi2 of the rheometer states
and the thinned profile together; beta and the lengths are fitted from those same measurements and
are shown with their own z, outside it. A benchmark: it prints, it asserts nothing.
"""
from __future__ import annotations

import argparse
import csv
import functools
import json
import math
import re
import sys
from dataclasses import dataclass
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipeline.calibration.calibrate import bulk_state, rheometer_laws  # noqa: E402
from pipeline.calibration.parameter_sets import calibration_settings  # noqa: E402
from pipeline.common.config import RHEOMETER  # noqa: E402
from pipeline.common.formats import open_fields  # noqa: E402
from pipeline.common.observables import creep_speed, replica_mean  # noqa: E402

REPLICA = re.compile(r"^(?P<state>.+)-r(?P<k>\d+)$")
#: Depth step (in d) of the thinned profile test: about the coarse-graining kernel's support.
THIN_EVERY = 3
#: mu / mu_s at which the creep is compared (issue 56, item 5); 0.1 apart in the thinned test.
MU_RATIO_LEVELS = tuple(round(0.5 + 0.05 * k, 2) for k in range(8))


def config_of(root: Path) -> dict[str, Any]:
    path = root / "config.effective.json"
    if not path.is_file():
        sys.exit(f"engine_crosscheck: {path}: missing (not an output root of the workflow?)")
    return json.loads(path.read_text())


def flat(d: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(d, dict):
        out: dict[str, Any] = {}
        for k, v in d.items():
            out |= flat(v, f"{prefix}.{k}" if prefix else str(k))
        return out
    return {prefix: d}


def config_differences(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    fa, fb = flat(a), flat(b)
    return [f"{k}: {fa.get(k)!r} | {fb.get(k)!r}" for k in sorted(set(fa) | set(fb))
            if fa.get(k) != fb.get(k) and k != "output_root"]


def combine(values: list[float], errors: list[float]) -> tuple[float, float]:
    """Mean of replicas and its error: the larger of the combined errors and the scatter / sqrt(n)."""
    v, e = np.array(values), np.array(errors)
    stated = float(np.sqrt(np.sum(e**2)) / len(v))
    scatter = float(v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else 0.0
    return float(v.mean()), max(stated, scatter)


def rheometer_states(root: Path, margin: float) -> dict[str, dict[str, tuple[float, float]]]:
    groups: dict[str, list[dict[str, float]]] = defaultdict(list)
    for path in sorted((root / "fields" / "rheometer").glob("*.nc")):
        m = REPLICA.match(path.stem)
        if m:
            groups[m["state"]].append(bulk_state(path, margin))
    single = sorted(state for state, reps in groups.items() if len(reps) == 1)
    if single:
        print(f"{root}: one replica of {', '.join(single)}: their errors are the time average's alone, without the "
              "packing's replica scatter (measured at I = 0.2 by LAMMPS: 3-12 x the time error of the wall gap): a chi2 on them "
              "overstates a difference")
    return {state: {q: combine([s[q] for s in reps], [s[f"{q}_err"] for s in reps]) for q in ("mu", "nu", "I")}
            for state, reps in groups.items()}


@dataclass
class Bed:
    """A gravity case's replicas in one root: each replica's ``(depth below its top contact plane,
    u, u's error, mu)`` profiles, the grain diameter, the wall speed (None if not recorded), the
    shallowest replica's depth between the contact planes and the bulk margin (m)."""
    d: float
    wall_speed: float | None
    depth_span: float
    margin: float
    replicas: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]


def bed_of(root: Path, case: str) -> Bed | None:
    """The replicas ``fields/<case>/r<k>.nc`` of ``root`` (None without any)."""
    files = sorted(p for p in (root / "fields" / case).glob("r*.nc") if re.fullmatch(r"r\d+", p.stem))
    if not files:
        return None
    replicas, spans = [], []
    for path in files:
        with open_fields(path) as ds:
            top = float(ds.attrs["z_top_contact_plane"])
            spans.append(top - float(ds.attrs.get("z_bottom_contact_plane", ds.attrs["z_bottom_wall"])))
            u, err, _ = creep_speed(ds)
            replicas.append((top - ds.z.values, u, err, ds["mu"].values))
            if path == files[0]:
                d, margin = float(ds.attrs["d"]), float(ds.attrs.get("bulk_margin_over_d", 3.0)) * float(ds.attrs["d"])
                speed = float(ds.attrs["wall_speed"]) if "wall_speed" in ds.attrs else None
    return Bed(d, speed, min(spans), margin, replicas)


def mean_profile(depths: np.ndarray, profiles: list[tuple[np.ndarray, np.ndarray, np.ndarray]]
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The replicas' mean and error at ``depths`` (:func:`replica_mean`); one replica's own values."""
    if len(profiles) > 1:
        return replica_mean(depths, profiles)
    own, value, error = profiles[0]
    order = np.argsort(own)
    return (np.interp(depths, own[order], value[order], left=np.nan, right=np.nan),
            np.interp(depths, own[order], error[order], left=np.nan, right=np.nan))


def creep_profile(root: Path, case: str) -> dict[int, tuple[float, float]]:
    """log10(u / V) of the replica mean and its error at whole d below the top contact plane."""
    bed = bed_of(root, case)
    if bed is None:
        return {}
    depths = np.arange(1, int(bed.depth_span / bed.d))
    u, err = mean_profile(depths * bed.d, [r[:3] for r in bed.replicas])
    v = bed.wall_speed if bed.wall_speed is not None else float(np.nanmax(u))
    out = {}
    for k, ui, ei in zip(depths, u, err):
        if np.isfinite(ui) and np.isfinite(ei) and ui > 2.0 * ei and ui > 0:
            out[int(k)] = (math.log10(ui / v), ei / (ui * math.log(10.0)))
    return out


def mu_s_of(root: Path) -> tuple[float, float]:
    """The root's calibrated mu_s and its error (NaN without a calibration)."""
    params = params_of(root)
    if params is None:
        return float("nan"), float("nan")
    entry = params["local"]["mu_s"]
    return float(entry["value"]), float(entry["error"])


def creep_at_mu_ratio(root: Path, case: str, mu_s_from: Path | None = None) -> dict[float, tuple[float, float]]:
    """log10(u / V) of the replica mean at each of ``MU_RATIO_LEVELS`` of mu / mu_s, with its error
    (module docstring), below the band (where mu / mu_s falls with depth) and where u > 2 errors.
    mu_s is the root's own calibration's, or ``mu_s_from``'s (a root of the same engine and law
    whose rheometer calibrated it, for a root that has none)."""
    mu_s, mu_s_err = mu_s_of(mu_s_from if mu_s_from is not None else root)
    bed = bed_of(root, case)
    if bed is None or bed.wall_speed is None or not math.isfinite(mu_s):
        return {}
    depths = np.arange(bed.d, bed.depth_span - bed.margin, 0.25 * bed.d)
    u, u_err = mean_profile(depths, [r[:3] for r in bed.replicas])
    mus = []
    for own, _, _, mu_own in bed.replicas:
        order = np.argsort(own)
        mus.append(np.interp(depths, own[order], mu_own[order], left=np.nan, right=np.nan))
    mu = np.nanmean(mus, axis=0)
    mu_err = np.nanstd(mus, axis=0, ddof=1) / math.sqrt(len(mus)) if len(mus) > 1 else np.full_like(mu, np.nan)
    x = mu / mu_s
    ok = np.isfinite(u) & np.isfinite(u_err) & (u > 2.0 * u_err) & (u > 0) & np.isfinite(x)
    # below the band only: from the depth where mu / mu_s first falls under 0.9, while it keeps falling
    start = int(np.argmax(ok & (x < 0.9))) if np.any(ok & (x < 0.9)) else len(x)
    stop = start
    while stop + 1 < len(x) and ok[stop + 1] and x[stop + 1] < x[stop] + 0.02:
        stop += 1
    if stop - start < 2:
        return {}
    sl = slice(start, stop + 1)
    xs, logu = x[sl], np.log10(u[sl] / bed.wall_speed)
    log_err = u_err[sl] / (u[sl] * math.log(10.0))
    x_err = np.hypot(mu_err[sl] / mu_s, xs * mu_s_err / mu_s)
    slope = np.gradient(logu, xs)
    order = np.argsort(xs)
    out = {}
    for level in MU_RATIO_LEVELS:
        if not xs.min() <= level <= xs.max():
            continue
        value = float(np.interp(level, xs[order], logu[order]))
        err = float(np.interp(level, xs[order], np.hypot(log_err, slope * x_err)[order]))
        out[level] = (value, err)
    return out


def csv_rows(path: Path) -> list[dict[str, str]]:
    if not path.is_file():
        return []
    with path.open() as f:
        return list(csv.DictReader(f))


def decades(root: Path, case: str) -> float:
    for row in csv_rows(root / "validation" / "creep_resolution.csv"):
        if row["case"] == case and row["run"].startswith("mean of"):
            return float(row["decades_best"])
    return float("nan")


def beta(root: Path) -> tuple[float, float]:
    for row in csv_rows(root / "validation" / "decay_length_fit.csv"):
        if row["source"] == "dem" and row["windows"] == "all windows":
            return float(row["beta"]), float(row["beta_err"])
    return float("nan"), float("nan")


def params_of(root: Path) -> dict[str, Any] | None:
    """``calibration/params.json`` of ``root`` (None before its calibration)."""
    path = root / "calibration" / "params.json"
    return json.loads(path.read_text()) if path.is_file() else None


@functools.lru_cache(maxsize=None)
def laws_of(root: Path) -> dict[str, Any] | None:
    """The local laws' ``local`` and ``covariance`` entries: the calibration's
    (``calibration/params.json``), or for a root without one (a study that ran the rheometer
    alone) the same fits on its rheometer fields (:func:`pipeline.calibration.calibrate.rheometer_laws`,
    said so on stdout); None without either."""
    params = params_of(root)
    if params is not None:
        return params
    files = sorted((root / "fields" / RHEOMETER).glob("*.nc"))
    if not files:
        return None
    margin = calibration_settings(config_of(root))["bulk_margin_over_d"]
    _, _, mu_fit, nu_fit = rheometer_laws(files, margin)
    print(f"{root}: no calibration; mu(I) and nu(I) fitted here on its {len(files)} rheometer fields files")
    laws = {"mu_i": mu_fit, "nu_i": nu_fit}
    return {"local": {n: {"value": fit.values[n], "error": fit.errors[n]} for fit in laws.values() for n in fit.names},
            "covariance": {law: {"names": list(fit.names), "matrix": np.asarray(fit.covariance).tolist()}
                           for law, fit in laws.items()},
            "fit_quality": {f"{law}_chi2_reduced": fit.chi2_reduced for law, fit in laws.items()}}


def local_law(root: Path) -> dict[str, tuple[float, float]]:
    """The calibrated local laws mu(I) and nu(I) (``calibration/params.json``'s ``local``): the
    states compared as curves, so a state whose realised I differs between the roots is read on
    the curve, not against the other root's different point."""
    params = laws_of(root)
    if params is None:
        return {}
    return {name: (float(e["value"]), float(e["error"]))
            for name, e in params["local"].items() if isinstance(e, dict) and "value" in e}


def law_chi2(root_a: Path, root_b: Path, law: str, scaled: bool = False) -> tuple[float, int, float] | None:
    """chi2 = D^T (C_a + C_b)^-1 D of a calibrated law's parameters (``covariance[law]`` of both
    roots' ``calibration/params.json``: the parameters' correlations counted), its dof and p.

    The covariances are the fits' with the states' errors taken as absolute. Where the law misses
    its states (the fit's reduced chi2 above 1: nu(I) = nu_c - a I at 17.5 on a root of 2026-12-07),
    they understate what the parameters are known to; ``scaled`` multiplies each root's by
    max(1, its fit's reduced chi2), the usual scale factor of a fit that does not describe its data."""
    pa, pb = laws_of(root_a), laws_of(root_b)
    if pa is None or pb is None:
        return None
    ca, cb = pa["covariance"].get(law), pb["covariance"].get(law)
    if ca is None or cb is None or ca["names"] != cb["names"]:
        return None
    diff = np.array([pb["local"][n]["value"] - pa["local"][n]["value"] for n in ca["names"]])
    factor = [max(1.0, fit_scale(root, law)) if scaled else 1.0 for root in (root_a, root_b)]
    cov = factor[0] * np.asarray(ca["matrix"]) + factor[1] * np.asarray(cb["matrix"])
    chi2 = float(diff @ np.linalg.solve(cov, diff))
    return chi2, len(diff), float(stats.chi2.sf(chi2, len(diff)))


def fit_scale(root: Path, law: str) -> float:
    """The reduced chi2 of ``root``'s fit of ``law`` (NaN without a calibration or fit; max(1, NaN)
    is 1: no scale)."""
    params = laws_of(root)
    return float((params or {}).get("fit_quality", {}).get(f"{law}_chi2_reduced", float("nan")))


def nonlocal_lengths(root: Path) -> dict[str, tuple[float, float]]:
    params = (params_of(root) or {}).get("nonlocal", {})
    return {f"{model}.{name}": (float(e["value"]), float(e.get("error", float("nan"))))
            for model, entries in params.items() for name, e in entries.items()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("root_a", type=Path)
    parser.add_argument("root_b", type=Path)
    parser.add_argument("--csv", type=Path, help="also write the table here")
    args = parser.parse_args(argv)
    ca, cb = config_of(args.root_a), config_of(args.root_b)
    ea, eb = (c["dem"].get("engine", "liggghts") for c in (ca, cb))
    print(f"A = {args.root_a} ({ea}), B = {args.root_b} ({eb})")
    diffs = [x for x in config_differences(ca, cb) if not x.startswith("dem.engine")]
    print("configs differ only in dem.engine" if not diffs else "configs ALSO differ in:\n  " + "\n  ".join(diffs))
    margin = float(ca.get("calibration", {}).get("bulk_margin_over_d", 3.0))
    rows: list[dict[str, Any]] = []

    def add(group: str, item: str, a: tuple[float, float], b: tuple[float, float]) -> None:
        err = math.hypot(a[1], b[1]) if all(math.isfinite(x) for x in (a[1], b[1])) else float("nan")
        z = (b[0] - a[0]) / err if err and math.isfinite(err) and err > 0 else float("nan")
        rows.append({"group": group, "item": item, "a": a[0], "a_err": a[1], "b": b[0], "b_err": b[1],
                     "b_minus_a": b[0] - a[0], "z": z})

    sa, sb = rheometer_states(args.root_a, margin), rheometer_states(args.root_b, margin)
    for state in sorted(set(sa) & set(sb)):
        for q in ("mu", "nu", "I"):
            add("rheometer", f"{state} {q}", sa[state][q], sb[state][q])
    planar = [c for c, spec in ca["cases"].items() if spec.get("geometry") == "planar_shear" and spec.get("gravity", 0) > 0
              and c in cb["cases"]]
    for case in planar:
        pa, pb = creep_profile(args.root_a, case), creep_profile(args.root_b, case)
        for k in sorted(set(pa) & set(pb)):
            add(f"creep {case}", f"log10 u/V at {k} d", pa[k], pb[k])
        ra, rb = creep_at_mu_ratio(args.root_a, case), creep_at_mu_ratio(args.root_b, case)
        for level in sorted(set(ra) & set(rb)):
            add(f"creep at mu/mu_s {case}", f"log10 u/V at mu/mu_s {level:.2f}", ra[level], rb[level])
        add(f"decades {case}", "decades resolved", (decades(args.root_a, case), float("nan")),
            (decades(args.root_b, case), float("nan")))
    add("beta", "beta (dem, all windows)", beta(args.root_a), beta(args.root_b))
    la, lb = local_law(args.root_a), local_law(args.root_b)
    for name in sorted(set(la) & set(lb)):
        add("local law", name, la[name], lb[name])
    la, lb = nonlocal_lengths(args.root_a), nonlocal_lengths(args.root_b)
    for name in sorted(set(la) & set(lb)):
        add("nonlocal", name, la[name], lb[name])

    print(f"\n{'group':<24} {'item':<28} {'A':>11} {'+-':>9} {'B':>11} {'+-':>9} {'B-A':>11} {'z':>7}")
    for r in rows:
        print(f"{r['group']:<24} {r['item']:<28} {r['a']:>11.4g} {r['a_err']:>9.2g} {r['b']:>11.4g} {r['b_err']:>9.2g} "
              f"{r['b_minus_a']:>11.3g} {r['z']:>7.2f}")
    print("\nTest: chi2 = sum z^2 over the group's terms (dof = terms); p = P(chi2_dof > chi2)")
    groups: dict[str, list[float]] = defaultdict(list)
    for r in rows:
        # the local law's parameters are correlated: tested below with their covariances
        if math.isfinite(r["z"]) and r["group"] != "local law":
            groups[r["group"]].append(r["z"])
    thinned = [r["z"] for r in rows if r["group"].startswith("creep ") and not r["group"].startswith("creep at")
               and math.isfinite(r["z"]) and int(r["item"].split()[-2]) % THIN_EVERY == 0]
    if thinned:
        groups[f"creep, every {THIN_EVERY} d"] = thinned
    at_ratio = [r["z"] for r in rows if r["group"].startswith("creep at mu/mu_s") and math.isfinite(r["z"])
                and round(float(r["item"].split()[-1]) * 10, 6) % 1 == 0]
    if at_ratio:
        groups["creep at mu/mu_s, every 0.1"] = at_ratio
    # The verdict: the measurements, not what is fitted from them (beta and the lengths are drawn
    # from the same creep and states, so counting them again would double their weight).
    groups[f"VERDICT: rheometer + creep every {THIN_EVERY} d"] = (
        [r["z"] for r in rows if r["group"] == "rheometer" and math.isfinite(r["z"])] + thinned)
    for name, zs in groups.items():
        chi2 = float(np.sum(np.square(zs)))
        p = float(stats.chi2.sf(chi2, len(zs)))
        print(f"  {name:<36} chi2 {chi2:8.2f} / {len(zs):3d} dof, p = {p:.3g}: "
              f"{'agree at 5 %' if p > 0.05 else 'DIFFER at 5 %'}")
    for law in ("mu_i", "nu_i"):
        for scaled in (False, True):
            found = law_chi2(args.root_a, args.root_b, law, scaled)
            if found is not None:
                chi2, dof, p = found
                label = f"calibrated {law} (covariances{' x max(1, chi2_red)' if scaled else ''})"
                print(f"  {label:<36} chi2 {chi2:8.2f} / {dof:3d} dof, p = {p:.3g}: "
                      f"{'agree at 5 %' if p > 0.05 else 'DIFFER at 5 %'}")
        print(f"    {law} fits' reduced chi2: A {fit_scale(args.root_a, law):.3g}, B {fit_scale(args.root_b, law):.3g}")
    if args.csv:
        with args.csv.open("w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
