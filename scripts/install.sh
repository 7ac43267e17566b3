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
# MPICH for LAMMPS (dem.engine: lammps): the mpich wheel's files unpacked into .venv/mpich, outside
# .venv/bin (Snakemake puts that first on PATH, and the wheel's mpirun there would start LIGGGHTS, an
# Open MPI program). pipeline/dem/engines/lammps.py puts .venv/mpich/lib on LD_LIBRARY_PATH.
mpich_version=5.0.2
if [ ! -f .venv/mpich/lib/libmpi.so.12 ] || [ "$(cat .venv/mpich/VERSION 2>/dev/null)" != "$mpich_version" ]; then
  wheels="$(mktemp -d)"
  .venv/bin/python -m pip download -q --no-deps -d "$wheels" "mpich==$mpich_version"
  rm -rf .venv/mpich.tmp
  .venv/bin/python - "$wheels" .venv/mpich.tmp "$mpich_version" <<'PY'
import glob, os, sys, zipfile
wheels, dest, version = sys.argv[1:]
prefix = f"mpich-{version}.data/data/"
with zipfile.ZipFile(glob.glob(os.path.join(wheels, f"mpich-{version}-*.whl"))[0]) as wheel:
    for info in wheel.infolist():
        if info.is_dir() or not info.filename.startswith(prefix):
            continue
        out = os.path.join(dest, info.filename[len(prefix):])
        os.makedirs(os.path.dirname(out), exist_ok=True)
        mode = info.external_attr >> 16
        if mode & 0o170000 == 0o120000:  # a symbolic link (libmpi.so -> libmpi.so.12)
            os.symlink(wheel.read(info).decode(), out)
            continue
        with wheel.open(info) as src, open(out, "wb") as dst:
            dst.write(src.read())
        os.chmod(out, mode & 0o777 or 0o644)
PY
  echo "$mpich_version" > .venv/mpich.tmp/VERSION
  rm -rf .venv/mpich "$wheels"
  mv .venv/mpich.tmp .venv/mpich
fi
