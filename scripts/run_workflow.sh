#!/usr/bin/env bash
# Install what is needed, then run the whole workflow on a config (default: config/config.yaml).
# Writes <output_root>/report.html (results/report.html for the default config).
# Extra arguments go to Snakemake as they are, targets and options alike, e.g.
# `bash scripts/run_workflow.sh config/ci.yaml --dry-run` or
# `bash scripts/run_workflow.sh config/ci.yaml results-ci/dem/rheometer/I0.2-P200-r1/run.json` (one DEM run;
# a target that is not a run of the config is refused in one line naming it).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$repo/scripts/install.sh"
cd "$repo"
configfile=config/config.yaml
if [[ $# -gt 0 && "$1" != -* ]]; then
  configfile="$1"
  shift
fi
# `--configfile FILE` would read every word after it up to the next option as one more config file
# (a target too); `--configfile=FILE` takes exactly one. scripts/snakemake.sh checks the config
# first: Snakemake names neither the file nor the line of a YAML error.
exec bash "$repo/scripts/snakemake.sh" --cores "${CORES:-$(nproc)}" --configfile="$configfile" "$@"
