"""What made a result: the config and the software versions, attached to every output file."""
from __future__ import annotations

import json
import platform
import shutil
import subprocess
from functools import lru_cache
from importlib import metadata
from pathlib import Path
from typing import Any

PACKAGES = ("granular-validate", "numpy", "scipy", "pandas", "xarray", "netCDF4", "pyvista", "matplotlib", "snakemake",
            "pypardiso", "mkl")


@lru_cache(maxsize=1)
def liggghts_version() -> str:
    """Version of the installed LIGGGHTS Debian package, or 'not installed'."""
    if shutil.which("dpkg-query") is None:
        return "unknown (no dpkg-query)"
    out = subprocess.run(
        ["dpkg-query", "-W", "-f", "${Version}", "liggghts"], capture_output=True, text=True, check=False
    )
    return out.stdout.strip() if out.returncode == 0 and out.stdout.strip() else "not installed"


@lru_cache(maxsize=1)
def source_commit() -> str:
    """The git commit of this checkout's code (``+modified`` when a tracked file differs from it),
    or why there is none: the package's version number does not change between commits, and a
    results root can hold files made by several (a step rerun after a change)."""
    repo = Path(__file__).resolve().parents[2]
    if shutil.which("git") is None or not (repo / ".git").exists():
        return "unknown (not a git checkout)"
    head = subprocess.run(["git", "-C", str(repo), "rev-parse", "HEAD"], capture_output=True, text=True, check=False)
    if head.returncode != 0:
        return f"unknown (git: {head.stderr.strip()[:120]})"
    dirty = subprocess.run(["git", "-C", str(repo), "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True, check=False).stdout.strip()
    return head.stdout.strip() + ("+modified" if dirty else "")


@lru_cache(maxsize=1)
def software_versions() -> dict[str, str]:
    """Versions of Python, the pinned packages, LIGGGHTS and this code's git commit."""
    versions = {"python": platform.python_version(), "liggghts": liggghts_version(),
                "granular-validate-commit": source_commit()}
    for name in PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def provenance(config: dict[str, Any]) -> dict[str, Any]:
    """A JSON-able record of the config and software versions."""
    return {"config": config, "software": software_versions()}


def provenance_attrs(config: dict[str, Any]) -> dict[str, str]:
    """The same record as NetCDF global attributes (strings)."""
    return {
        "config_json": json.dumps(config, sort_keys=True),
        "software_versions_json": json.dumps(software_versions(), sort_keys=True),
    }
