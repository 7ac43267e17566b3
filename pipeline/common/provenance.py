"""What made a result: the config and the software versions, attached to every output file."""
from __future__ import annotations

import json
import platform
import shutil
import subprocess
from functools import lru_cache
from importlib import metadata
from typing import Any

PACKAGES = ("granular-validate", "numpy", "scipy", "pandas", "xarray", "netCDF4", "pyvista", "matplotlib", "snakemake")


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
def software_versions() -> dict[str, str]:
    """Versions of Python, the pinned packages and LIGGGHTS."""
    versions = {"python": platform.python_version(), "liggghts": liggghts_version()}
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
