#!/usr/bin/env bash
# Snakemake of the project's .venv, with every --configfile checked first: Snakemake parses a
# config file before the Snakefile runs and names neither the file nor the line of a YAML error
# (or of an empty file); pipeline.workflow check-config names both. Arguments go to Snakemake.
# `--configfile A B` reads B as a config file too: a B that is no file (a target given after the
# config) is refused here in one line, with the two ways to give it as a target.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
check() { "$repo/.venv/bin/python" -m pipeline.workflow check-config "$1" > /dev/null; }
args=("$@")
for ((i = 0; i < ${#args[@]}; i++)); do
  case "${args[i]}" in
    --configfile|--configfiles)
      for ((j = i + 1; j < ${#args[@]}; j++)); do
        [[ "${args[j]}" == -* ]] && break
        if ((j > i + 1)) && [[ ! -f "${args[j]}" ]]; then
          echo "error: ${args[j]}: read as a config file (every word after ${args[i]} up to the next option is one)," \
               "and there is no such file; a target goes before ${args[i]}, or after ${args[i]}=${args[i + 1]}" >&2
          exit 1
        fi
        check "${args[j]}"
      done ;;
    --configfile=*|--configfiles=*)
      check "${args[i]#*=}" ;;
  esac
done
# Snakemake 9.27 starts a timer of --max-jobs-per-timespan's span after every scheduling pass, a
# pass run because a job ended included: every finished job adds a chain of passes, one per span
# (Snakemake's default 100/1s), for the rest of the run. Over the default's 247 jobs its process
# took 903 CPU s (0.12 of a core) from the DEM (docs/dem_cost.md 34). The same rate over 10 s makes
# the passes ten times fewer: 152 CPU s in the next default run (36); the exit waits up to one span
# for the last timers. Left out where
# the user sets the rate or a profile (a site's profile may set its own).
rate=(--max-jobs-per-timespan 1000/10s)
for a in "$@"; do
  case "$a" in
    --max-jobs-per-timespan*|--max-jobs-per-second*|--profile*|--workflow-profile*) rate=() ;;
  esac
done
exec "$repo/.venv/bin/snakemake" "${rate[@]}" "$@"
