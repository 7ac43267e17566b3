#!/usr/bin/env bash
# Install what is needed, then run the whole workflow on a config (default: config/config.yaml).
# Writes <output_root>/report.html (results/report.html for the default config).
# Extra arguments go to Snakemake, e.g. `bash scripts/run_workflow.sh config/ci.yaml --dry-run`.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$repo/scripts/install.sh"
cd "$repo"
configfile="${1:-config/config.yaml}"
shift || true
# Snakemake does not name the file or line of a YAML error: check the config first.
.venv/bin/python -m pipeline.workflow check-config "$configfile"
exec .venv/bin/snakemake --cores "${CORES:-$(nproc)}" --configfile "$configfile" "$@"
