#!/usr/bin/env bash
# Snakemake of the project's .venv, with every --configfile checked first: Snakemake parses a
# config file before the Snakefile runs and names neither the file nor the line of a YAML error
# (or of an empty file); pipeline.workflow check-config names both. Arguments go to Snakemake.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
args=("$@")
for ((i = 0; i < ${#args[@]}; i++)); do
  case "${args[i]}" in
    --configfile|--configfiles)
      for ((j = i + 1; j < ${#args[@]}; j++)); do
        [[ "${args[j]}" == -* ]] && break
        "$repo/.venv/bin/python" -m pipeline.workflow check-config "${args[j]}" > /dev/null
      done ;;
    --configfile=*)
      "$repo/.venv/bin/python" -m pipeline.workflow check-config "${args[i]#--configfile=}" > /dev/null ;;
  esac
done
exec "$repo/.venv/bin/snakemake" "$@"
