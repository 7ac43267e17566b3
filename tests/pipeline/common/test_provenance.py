"""pipeline.common.provenance: every result file names the code that made it (the git commit, and
whether a tracked file differed from it), not only the package's version number."""
from __future__ import annotations

import subprocess
from pathlib import Path

from pipeline.common.provenance import source_commit

REPO = Path(__file__).resolve().parents[3]


def test_the_commit_is_this_checkouts_head() -> None:
    head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "HEAD"], capture_output=True, text=True,
                          check=True).stdout.strip()
    dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True, check=True).stdout.strip()
    assert source_commit() == head + ("+modified" if dirty else "")
