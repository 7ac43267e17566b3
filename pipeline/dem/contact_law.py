"""The contact law's one switch: ``material.tangential_damping`` (docs/dem.md, "Two engines").

Absent or ``true``: the law every run had before the key existed, tangential damping on, and the
templates are copied byte for byte (no run's rendered input changes, so no run is re-run).
``false``: the copied templates' contact law is rewritten, in both engines, to the one law both can
run (the terms that then still differ are listed in docs/dem.md):

* LIGGGHTS 3.8: the ``gran model hertz`` option ``tangential_damping off`` (``normal_model_hertz.h``:
  ``if (!tangential_damping) gammat = 0.0``), appended to every ``model hertz tangential history``
  line (``pair_style`` and the pour's ``fix wall/gran``; ``wall/gran`` takes it only after its
  wall arguments, so it goes at the end of the line).
* LAMMPS: ``tangential mindlin NULL 0.0 mu`` in place of ``tangential mindlin NULL x_gamma_t mu``:
  the same sub-model (k_t = 8 G* a, a = sqrt(R* delta), as LIGGGHTS' 8 G* sqrt(R* delta)) with its
  damping coefficient 0. With no damping its Coulomb test is on the spring alone and its reset on
  sliding leaves the spring at exactly mu F_n (``sub3(fs, fdamp, history)`` with fdamp = 0), as
  LIGGGHTS'. What still differs: ``mindlin`` rotates the history into the new tangent plane keeping
  its length, then adds v_t dt (LIGGGHTS adds, then projects: a length loss of 1 - cos(dtheta) per
  step, dtheta the normal's turn in the step), and the lever arm of the spin in v_t (r, LIGGGHTS'
  r - delta/2). ``mindlin_classic`` (gran/hertz/history's law) would match the rotation too, but in
  the installed wheel (22 Jul 2025) its reset on sliding divides the capped force by k_t, not by
  k_t a (``scale3(-1.0 / k, history)``; fixed upstream since): the spring falls to a times its value,
  about nothing, at every sliding step (F_t a sawtooth from 0 to mu F_n, measured by
  benchmarks/two_grain_contact.py's replay). ``linear_history`` has a constant k_t (not Hertz-Mindlin).
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

#: The config key (in ``material``) and its value when absent.
KEY = "tangential_damping"
DEFAULT = True

#: LIGGGHTS: the contact model every template names, and the option that switches its damping off.
LIGGGHTS_MODEL = "model hertz tangential history"
LIGGGHTS_OFF = "tangential_damping off"
#: LAMMPS: the tangential sub-model of lammps_inputs/ (damping on) and its replacement (damping off).
LAMMPS_MINDLIN = "tangential mindlin NULL ${tangential_damping_ratio} ${friction}"
LAMMPS_UNDAMPED = "tangential mindlin NULL 0.0 ${friction}"


class ContactLawError(ValueError):
    """The switch cannot be honoured: a bad value, or a template whose law the switch does not know."""


def tangential_damping(material: Mapping[str, Any] | None) -> bool:
    """``material.tangential_damping``: ``True`` when absent (the law of every run before the key)."""
    value = (material or {}).get(KEY, DEFAULT)
    if not isinstance(value, bool):
        raise ContactLawError(f"material.{KEY} must be true or false, got {value!r}")
    return value


def liggghts_undamped(text: str) -> tuple[str, int]:
    """LIGGGHTS template text with ``tangential_damping off`` on each contact-model line; the count."""
    out, count = [], 0
    for line in text.splitlines(keepends=True):
        content = line.rstrip("\r\n")
        body, hash_, comment = content.partition("#")
        if LIGGGHTS_MODEL in body and LIGGGHTS_OFF not in body:
            body = f"{body.rstrip()} {LIGGGHTS_OFF}" + (" " if hash_ else "")
            count += 1
        out.append(body + hash_ + comment + line[len(content):])
    return "".join(out), count


def lammps_undamped(text: str) -> tuple[str, int]:
    """LAMMPS template text with ``mindlin``'s tangential damping coefficient 0; the count."""
    return text.replace(LAMMPS_MINDLIN, LAMMPS_UNDAMPED), text.count(LAMMPS_MINDLIN)


_REWRITE = {"liggghts": liggghts_undamped, "lammps": lammps_undamped}


def apply(engine: str, run_dir: Path, names: list[str], damping: bool, law_file: str = "materials.in") -> None:
    """Give the templates ``names`` copied into ``run_dir`` the law of ``damping`` (``engine``'s syntax).

    With damping (the default law) nothing is touched. Without, every occurrence of the law is
    rewritten; ``law_file`` (the pair style's) must hold one, or :class:`ContactLawError` is raised.
    """
    if damping:
        return
    rewrite = _REWRITE[engine]
    for name in names:
        path = run_dir / name
        text, count = rewrite(path.read_text())
        if name == law_file and count == 0:
            raise ContactLawError(f"{path}: material.{KEY}: false, but the {engine} contact law in it is not the "
                                  f"one the switch rewrites ({LIGGGHTS_MODEL if engine == 'liggghts' else LAMMPS_MINDLIN!r})")
        if count:
            path.write_text(text)
