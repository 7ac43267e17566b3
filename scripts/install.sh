#!/usr/bin/env bash
# Idempotent set-up for a fresh Debian machine (run as root): LIGGGHTS from Debian without its
# recommended ParaView, Python with venv, and this package with its pinned dependencies in .venv.
# Safe to run again: each step is skipped when already done.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"

# --tests: also what only the tests use (headless Chromium reads the report as a person would).
for_tests=0
[ "${1:-}" = "--tests" ] && for_tests=1

need_apt=()
command -v liggghts >/dev/null 2>&1 || need_apt+=(liggghts)
if [ "$for_tests" = 1 ]; then
  command -v chromium >/dev/null 2>&1 || need_apt+=(chromium)
fi
command -v mpirun >/dev/null 2>&1 || need_apt+=(openmpi-bin)
command -v python3 >/dev/null 2>&1 || need_apt+=(python3)
# A C compiler builds the fast dump parser (pipeline/dumps/fastparse.py) on first use.
command -v cc >/dev/null 2>&1 || need_apt+=(gcc libc6-dev)
if command -v python3 >/dev/null 2>&1 && ! python3 -c "import venv, ensurepip" >/dev/null 2>&1; then
  need_apt+=(python3-venv)
fi
if [ ${#need_apt[@]} -gt 0 ]; then
  if [ "$(id -u)" -ne 0 ]; then
    echo "install.sh: need root to install ${need_apt[*]} with apt-get" >&2
    exit 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${need_apt[@]}"
fi

if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
# Reinstall only when the pinned dependencies changed.
stamp=.venv/.granular-validate-installed
want="$(sha256sum pyproject.toml | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
  .venv/bin/python -m pip install -q --upgrade pip
  .venv/bin/python -m pip install -q -e ".[test]"
  echo "$want" > "$stamp"
fi
