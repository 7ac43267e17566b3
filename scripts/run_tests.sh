#!/usr/bin/env bash
# Install what is needed, then run the test suite (including a reduced run of the real workflow
# with the real LIGGGHTS binary). Extra arguments go to pytest.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$repo/scripts/install.sh" --tests
cd "$repo"
exec .venv/bin/python -m pytest "$@"
