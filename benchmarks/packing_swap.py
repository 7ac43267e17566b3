"""Which makes the two engines' creeping beds differ: the pour or the shear? (issue 56, item 3)

Four roots of the calibration case ``shear_gravity`` on one contact law (tangential damping off),
a 2 x 2 of engine (who shears) and pour (who poured the packing):

    LIGGGHTS sheared, LIGGGHTS poured   results-damping-off                (damping_off_liggghts.yaml)
    LAMMPS   sheared, LAMMPS   poured   results-lammps-damping-off         (damping_off_lammps.yaml)
    LAMMPS   sheared, LIGGGHTS poured   results-lammps-liggghts-packing    (packing_swap_lammps.yaml)
    LIGGGHTS sheared, LAMMPS   poured   results-liggghts-lammps-packing    (packing_swap_liggghts.yaml)

For each root, the replicas' bulk solid fraction (fields attrs ``bulk_nu``, 3 d from the walls), the
bed height (top minus bottom contact plane), the settled gap before the wall's load, the top wall's
height per chunk (``c_htop`` of the series) and the creep profile log10(u / V) at whole d. Then the
two effects, each with the other held: the engine's (same pour, other shearer) and the pour's (same
shearer, other pour), each a Welch t over the replicas for nu and the height, and a chi2 over the
creep profile every 3 d and at whole d (z per depth from the replica means' errors), and at equal
mu / mu_s (engine_crosscheck.creep_at_mu_ratio, mu_s the shearer's own calibration's: the law is the
engine's, whoever poured). A replica's series and fields
are its own: the four replicas of a root are independent packings (seeds r1-r4, shared across roots).

Usage: .venv/bin/python benchmarks/packing_swap.py [--liggghts R] [--lammps R] [--lammps-on-liggghts R]
       [--liggghts-on-lammps R]
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from engine_crosscheck import creep_at_mu_ratio, creep_profile  # noqa: E402
from pipeline.common.formats import open_fields  # noqa: E402

CASE = "shear_gravity"
#: The chunks whose top-wall height is printed: the first shear chunk (the loaded wall comes
#: down), the fourth, the sixteenth and the last of production.
CHUNKS = (0, 3, 15, -1)


def htop_per_chunk(run_dir: Path, d: float, kinds: tuple[str, ...] = ("shear", "production")) -> list[float]:
    """The top wall's mean height (the series' c_htop, in d) over each chunk of ``kinds``, in order."""
    files = [f for kind in kinds for f in sorted((run_dir / "series").glob(f"{kind}_*.txt"))]
    return [float(np.loadtxt(f, comments="#", ndmin=2)[:, 6].mean()) / d for f in files]


def replicas(root: Path) -> list[dict[str, float]]:
    """Per replica: bulk nu and its error, bed height / d, settled gap / d, c_htop / d per chunk."""
    out = []
    for path in sorted((root / "fields" / CASE).glob("r*.nc")):
        with open_fields(path) as ds:
            d = float(ds.attrs["d"])
            row = {"run": path.stem, "nu": float(ds.attrs["bulk_nu"]), "nu_err": float(ds.attrs["bulk_nu_err"]),
                   "height": (float(ds.attrs["z_top_contact_plane"]) - float(ds.attrs["z_bottom_contact_plane"])) / d}
        run_dir = root / "dem" / CASE / path.stem
        state = json.loads((run_dir / "state.json").read_text())  # the lifecycle's, with the fill's record
        row["settled_gap"] = state["fill"]["settled_gap"] / d
        htop = htop_per_chunk(run_dir, d)
        row["htop"] = [htop[k] for k in CHUNKS] if len(htop) > max(CHUNKS) else []
        row["packing_from"] = (state["fill"].get("packing_from") or {}).get("path", "own pour")
        out.append(row)
    return out


def mean_se(values: list[float]) -> tuple[float, float]:
    a = np.asarray(values, dtype=float)
    return float(a.mean()), float(a.std(ddof=1) / math.sqrt(len(a))) if len(a) > 1 else float("nan")


def welch(a: list[float], b: list[float]) -> tuple[float, float, float]:
    """Difference b - a, Welch t and its two-sided p."""
    t, p = stats.ttest_ind(b, a, equal_var=False)
    return float(np.mean(b) - np.mean(a)), float(t), float(p)


def creep_chi2(a: dict[int, tuple[float, float]], b: dict[int, tuple[float, float]], step: int = 3
               ) -> tuple[float, int, float, list[str]]:
    """chi2 over the depths both resolve, every ``step`` d from 1 d (points closer share the kernel)."""
    depths = [k for k in sorted(set(a) & set(b)) if (k - 1) % step == 0]
    z = [(b[k][0] - a[k][0]) / math.hypot(a[k][1], b[k][1]) for k in depths]
    chi2 = float(np.sum(np.square(z)))
    text = [f"{k} d: {b[k][0] - a[k][0]:+.2f} (z {zk:+.1f})" for k, zk in zip(depths, z)]
    return chi2, len(depths), float(stats.chi2.sf(chi2, len(depths))) if depths else float("nan"), text


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--liggghts", default="results-damping-off", help="LIGGGHTS sheared, LIGGGHTS poured")
    parser.add_argument("--lammps", default="results-lammps-damping-off", help="LAMMPS sheared, LAMMPS poured")
    parser.add_argument("--lammps-on-liggghts", default="results-lammps-liggghts-packing",
                        help="LAMMPS sheared, LIGGGHTS poured")
    parser.add_argument("--liggghts-on-lammps", default="results-liggghts-lammps-packing",
                        help="LIGGGHTS sheared, LAMMPS poured")
    args = parser.parse_args(argv)
    cells = {("liggghts", "liggghts"): Path(args.liggghts), ("lammps", "lammps"): Path(args.lammps),
             ("lammps", "liggghts"): Path(args.lammps_on_liggghts), ("liggghts", "lammps"): Path(args.liggghts_on_lammps)}
    data, creep, at_mu = {}, {}, {}
    print(f"case {CASE}; per root the replicas' mean +- standard error (heights in d)")
    print(f"{'sheared by':>10} {'poured by':>10}  {'root':34} {'n':>2} {'bulk nu':>16} {'bed height':>14} "
          f"{'settled gap':>14}  htop at chunk {', '.join(str(c) for c in CHUNKS)}")
    for (shearer, pourer), root in cells.items():
        if not (root / "fields" / CASE).is_dir():
            print(f"{shearer:>10} {pourer:>10}  {str(root):34} (no fields: not run)")
            continue
        reps = replicas(root)
        data[(shearer, pourer)] = reps
        creep[(shearer, pourer)] = creep_profile(root, CASE)
        # mu_s is the shearer's law's: its own-pour root's rheometer calibrated it.
        at_mu[(shearer, pourer)] = creep_at_mu_ratio(root, CASE, mu_s_from=cells[(shearer, shearer)])
        nu, nu_se = mean_se([r["nu"] for r in reps])
        h, h_se = mean_se([r["height"] for r in reps])
        g, g_se = mean_se([r["settled_gap"] for r in reps])
        htop = [mean_se([r["htop"][k] for r in reps if r["htop"]]) for k in range(len(CHUNKS))] \
            if all(r["htop"] for r in reps) else []
        print(f"{shearer:>10} {pourer:>10}  {str(root):34} {len(reps):>2} {nu:.4f} +- {nu_se:.4f} "
              f"{h:6.2f} +- {h_se:4.2f} {g:6.2f} +- {g_se:4.2f}  "
              + ", ".join(f"{m:.2f}+-{s:.2f}" for m, s in htop))
        sources = sorted({r["packing_from"].split("/dem/")[0] for r in reps})
        if sources != ["own pour"]:
            print(f"{'':24}packings from {', '.join(sources)}")

    def effect(label: str, a: tuple[str, str], b: tuple[str, str]) -> None:
        if a not in data or b not in data:
            return
        print(f"\n{label}: ({b[0]} sheared, {b[1]} poured) - ({a[0]} sheared, {a[1]} poured)")
        paired = [r["run"] for r in data[a]] == [r["run"] for r in data[b]]
        for q in ("nu", "height", "settled_gap"):
            diff, t, p = welch([r[q] for r in data[a]], [r[q] for r in data[b]])
            line = f"  {q:12} {diff:+.4f}  Welch t {t:+.2f}, p {p:.3g}"
            if paired and a[1] == b[1]:
                # The same pour: replica k starts from the same packing in both, so the pairs are matched.
                pairs = [rb[q] - ra[q] for ra, rb in zip(data[a], data[b])]
                tp, pp = stats.ttest_1samp(pairs, 0.0)
                line += f"; paired by replica {', '.join(f'{v:+.4f}' for v in pairs)}: t {tp:+.2f}, p {pp:.3g}"
            print(line)
        chi2, dof, p, text = creep_chi2(creep[a], creep[b])
        print(f"  creep every 3 d: chi2 {chi2:.2f} / {dof}, p {p:.3g}; " + "; ".join(text))
        chi2, dof, p, text = creep_chi2(creep[a], creep[b], step=1)
        print(f"  creep at whole d: chi2 {chi2:.2f} / {dof}, p {p:.3g}")
        levels = sorted(set(at_mu[a]) & set(at_mu[b]))
        z = [(at_mu[b][x][0] - at_mu[a][x][0]) / math.hypot(at_mu[a][x][1], at_mu[b][x][1]) for x in levels]
        if levels:
            chi2 = float(np.sum(np.square(z)))
            print(f"  creep at equal mu / mu_s ({levels[0]:.2f}-{levels[-1]:.2f}, each shearer's own mu_s): chi2 {chi2:.2f} / "
                  f"{len(levels)}, p {stats.chi2.sf(chi2, len(levels)):.3g}; largest |z| {max(abs(v) for v in z):.1f}")

    effect("The engine's effect, LIGGGHTS's pour", ("liggghts", "liggghts"), ("lammps", "liggghts"))
    effect("The engine's effect, LAMMPS's pour", ("liggghts", "lammps"), ("lammps", "lammps"))
    effect("The pour's effect, sheared by LAMMPS", ("lammps", "liggghts"), ("lammps", "lammps"))
    effect("The pour's effect, sheared by LIGGGHTS", ("liggghts", "liggghts"), ("liggghts", "lammps"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
