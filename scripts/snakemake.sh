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
exec "$repo/.venv/bin/snakemake" "$@"
