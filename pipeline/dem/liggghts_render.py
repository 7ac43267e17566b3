"""Render LIGGGHTS stage inputs from the templates in ``liggghts_inputs/``.

A template is plain LIGGGHTS input that reads its parameters as LIGGGHTS variables (``${name}``).
Rendering writes, in the run folder, a copy of the templates and one small stage input per
LIGGGHTS call (``in.<stage>``) that defines every variable with ``variable name string value``
and then includes the stage template. The run folder therefore holds the input exactly as run.
Rendering refuses a template that reads a variable nobody defines.
"""
from __future__ import annotations

import re
import shutil
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

from pipeline.common.config import size_classes
from pipeline.dem import contact_law

TEMPLATE_ROOT = Path(__file__).resolve().parents[2] / "liggghts_inputs"
#: Templates every geometry's stages include: the settings, the materials, the top wall's motion and
#: the pair-force sums (the last two in every shear stage, see docs/dem.md "Action and reaction").
SHARED_TEMPLATES = ("common_settings.in", "materials.in", "top_wall_drive.in", "pair_force.in")

_USE = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)\}")
_DEFINE = re.compile(r"^\s*variable\s+([A-Za-z_][A-Za-z0-9_]*)\s", re.MULTILINE)
_INCLUDE = re.compile(r"^\s*include\s+(\S+)", re.MULTILINE)


#: Include files the pipeline writes at run time (not templates).
GENERATED_INCLUDES = ("grains.in", "bottom_wall.in", "top_wall.in")


class TemplateError(ValueError):
    """A template reads a variable that is not defined, or a template file is missing."""


def template_files(geometry: str) -> list[Path]:
    """The template files of a geometry (stage templates plus the shared ones)."""
    folder = TEMPLATE_ROOT / geometry
    if not folder.is_dir():
        raise TemplateError(f"no LIGGGHTS templates for geometry {geometry!r} (looked in {folder})")
    return [TEMPLATE_ROOT / name for name in SHARED_TEMPLATES] + sorted(folder.glob("*.in"))


def copy_templates(geometry: str, run_dir: Path, tangential_damping: bool = True) -> None:
    """Copy the geometry's templates into ``run_dir`` (stage inputs include them by name).

    ``tangential_damping`` (``material.tangential_damping``, :mod:`pipeline.dem.contact_law`): with
    it (the default) the copies are the templates byte for byte; without, their contact-model lines
    get LIGGGHTS' ``tangential_damping off``.
    """
    run_dir.mkdir(parents=True, exist_ok=True)
    paths = template_files(geometry)
    for path in paths:
        shutil.copyfile(path, run_dir / path.name)
    contact_law.apply("liggghts", run_dir, [path.name for path in paths], tangential_damping)


def _strip_comments(text: str) -> str:
    return "\n".join(line.split("#", 1)[0] for line in text.splitlines())


def variables_read(template: Path, generated: Iterable[str] = GENERATED_INCLUDES) -> set[str]:
    """Variables a template (and the templates it includes) reads but does not define itself.

    ``generated`` names include files written at run time (:data:`GENERATED_INCLUDES`): they are
    not followed, since they define nothing the templates read.
    """
    seen: set[Path] = set()
    used: set[str] = set()
    defined: set[str] = set()
    skip = set(generated)

    def visit(path: Path) -> None:
        if path in seen:
            return
        seen.add(path)
        text = _strip_comments(path.read_text())
        used.update(_USE.findall(text))
        defined.update(_DEFINE.findall(text))
        for name in _INCLUDE.findall(text):
            if "${" in name or name in skip:
                continue
            target = path.parent / name
            if not target.exists():
                target = TEMPLATE_ROOT / name
            if not target.exists():
                raise TemplateError(f"{path}: includes {name}, which is not a template")
            visit(target)

    visit(template)
    return used - defined


def format_value(value: object) -> str:
    """LIGGGHTS text of a variable value (floats at full precision)."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return " ".join(format_value(v) for v in value)
    return str(value)


def render_stage(
    run_dir: Path,
    stage: str,
    template: str,
    variables: Mapping[str, object],
    generated: Sequence[str] = GENERATED_INCLUDES,
) -> Path:
    """Write ``run_dir/in.<stage>``: the variable definitions, then ``include <template>``.

    Raises:
        TemplateError: the template reads a variable missing from ``variables``.
    """
    template_path = run_dir / template
    if not template_path.exists():
        raise TemplateError(f"{template_path}: template not copied into the run folder")
    missing = variables_read(template_path, generated) - set(variables)
    if missing:
        raise TemplateError(f"{template}: variables not defined for stage {stage!r}: {', '.join(sorted(missing))}")
    lines = [f"# Stage '{stage}': generated by pipeline/dem/liggghts_render.py from {template}"]
    for name, value in variables.items():
        text = format_value(value)
        if '"' in text:
            raise TemplateError(f"variable {name!r}: value {text!r} contains a double quote")
        lines.append(f'variable {name} string "{text}"')
    lines.append(f"include {template}")
    path = run_dir / f"in.{stage}"
    path.write_text("\n".join(lines) + "\n")
    return path


def grains_include(
    d: float, polydispersity: float, n_sizes: int, rho_s: float, seeds: Sequence[int], distribution_seed: int
) -> str:
    """LIGGGHTS text defining the grain-size distribution ``pdd``.

    Diameters are ``n_sizes`` equally spaced values in ``d * (1 +- polydispersity)``, inserted in
    equal numbers (``particledistribution/discrete/numberbased``), so the number-mean diameter is d.
    """
    if len(seeds) != n_sizes:
        raise ValueError(f"need {n_sizes} template seeds, got {len(seeds)}")
    diameters = size_classes(d, polydispersity, n_sizes)
    lines = []
    for k, (diameter, seed) in enumerate(zip(diameters, seeds, strict=True), start=1):
        lines.append(
            f"fix pts{k} all particletemplate/sphere {seed} atom_type 1 "
            f"density constant {rho_s!r} radius constant {0.5 * diameter!r}"
        )
    pairs = " ".join(f"pts{k} {1.0 / n_sizes!r}" for k in range(1, n_sizes + 1))
    lines.append(f"fix pdd all particledistribution/discrete/numberbased {distribution_seed} {n_sizes} {pairs}")
    return "\n".join(lines) + "\n"

