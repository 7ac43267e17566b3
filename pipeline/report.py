"""Write the comparison report ``report.html`` from the files the stages wrote.

Usage: ``python -m pipeline.report --config RESULTS/config.effective.json --out RESULTS/report.html``
"""
from __future__ import annotations

import argparse
import html
import json
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import pandas as pd

from pipeline.config import dem_runs, load_config
from pipeline.html_report import figure_html, page, table_html
from pipeline.provenance import software_versions
from pipeline.wall_series import read_wall_series


def load_runs(config: dict[str, Any]) -> list[dict[str, Any]]:
    """The run.json record of every DEM run, with its folder under ``_dir``."""
    root = Path(config["output_root"])
    runs = []
    for case, run in dem_runs(config):
        run_dir = root / "dem" / case / run
        path = run_dir / "run.json"
        if not path.exists():
            raise FileNotFoundError(f"{path}: DEM run {case}/{run} has no run.json (did the dem rule finish?)")
        record = json.loads(path.read_text())
        record["_dir"] = run_dir
        runs.append(record)
    return runs


def dem_table(runs: list[dict[str, Any]]) -> pd.DataFrame:
    """One row per DEM run: size, cost and the steady window."""
    rows = []
    for r in runs:
        rows.append(
            {
                "case": r["case"],
                "run": r["run"],
                "grains": r["particle_count"],
                "wall speed (m/s)": r["wall_speed"],
                "steps": r["steps"],
                "dt (s)": r["time_step"],
                "LIGGGHTS seconds": r["wall_clock_seconds"],
                "MPI ranks": r["mpi_ranks"],
                "steady from (s)": r["steady_state_window"][0],
                "end (s)": r["steady_state_window"][1],
                "max overlap / d": r["max_overlap_over_d"],
            }
        )
    return pd.DataFrame(rows)


def wall_series_figure(runs: list[dict[str, Any]]) -> str:
    """Wall friction coefficient and wall height against time, steady window shaded."""
    fig, (ax_mu, ax_h) = plt.subplots(1, 2, figsize=(11, 4))
    for r in runs:
        frames = []
        for series in sorted((r["_dir"] / "series").glob("*.txt")):
            frames.append(read_wall_series(series))
        data = pd.concat(frames, ignore_index=True).sort_values("time")
        area = r["cell"][0] * r["cell"][1]
        label = f"{r['case']}/{r['run']}"
        (line,) = ax_mu.plot(data["time"], -data["ftop_x"] / area / r["wall_pressure"], lw=0.8, label=label)
        ax_h.plot(data["time"], (data["h_top"] - data["h_top"].iloc[-1]) / r["d"], lw=0.8, color=line.get_color())
        t0, t1 = r["steady_state_window"]
        ax_mu.axvspan(t0, t1, color=line.get_color(), alpha=0.08)
    ax_mu.set_xlabel("time t (s)")
    ax_mu.set_ylabel("wall shear stress / wall pressure (-)")
    ax_h.set_xlabel("time t (s)")
    ax_h.set_ylabel("top-wall height minus final height, in d (-)")
    ax_mu.legend(fontsize=7)
    return figure_html(fig, "Top-wall shear stress over the imposed normal stress, and wall height; shaded: steady window detected from the data.")


def build_report(config: dict[str, Any]) -> str:
    """The whole HTML report."""
    runs = load_runs(config)
    sections = [
        "<h2>DEM runs</h2>",
        "<p class='note'>LIGGGHTS, Hertz contacts with tangential history, polydisperse spheres; "
        "rough walls made of frozen grains. Stiffness and time step follow the rules in "
        "<code>pipeline/contact_scaling.py</code>.</p>",
        table_html(dem_table(runs)),
        wall_series_figure(runs),
        "<h2>Provenance</h2>",
        table_html(pd.DataFrame(sorted(software_versions().items()), columns=["software", "version"])),
        f"<details><summary>configuration</summary><pre>{html.escape(json.dumps(config, indent=1))}</pre></details>",
    ]
    return page("granular-validate: continuum rheologies against DEM", sections)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Write the comparison report (self-contained HTML).")
    parser.add_argument("--config", required=True)
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    config = load_config(args.config)
    out = Path(args.out)
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(build_report(config))
    tmp.replace(out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
