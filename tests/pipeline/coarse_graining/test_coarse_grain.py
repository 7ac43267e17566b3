"""Coarse-graining on synthetic configurations with exact answers.

Integrals over z are taken with the trapezoid rule on a fine grid. The Lucy kernel is twice
continuously differentiable, so that rule's error is far below the tolerances used; the Gaussian
is cut at 3 w, a jump of 0.4 % of its peak, so integral checks with it use the Lucy kernel or a
tolerance derived from that jump.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from pipeline.coarse_graining import coarse_grain as cg
from pipeline.coarse_graining import plane
from pipeline.coarse_graining import dumps_cli
from pipeline.coarse_graining.kernels import Kernel, segment_2d

KERNELS = [Kernel("gaussian", 1.0e-3), Kernel("lucy", 1.0e-3)]


def snapshot(pos, vel, mass, radius, r1=None, branch=None, force=None, box=None, body=None):
    pos = np.asarray(pos, float)
    n = len(pos)
    return cg.SnapshotData(
        pos=pos, vel=np.asarray(vel, float), mass=np.asarray(mass, float) * np.ones(n),
        volume=4 / 3 * np.pi * (np.asarray(radius, float) * np.ones(n)) ** 3,
        body=np.ones(n, bool) if body is None else body,
        r1=np.zeros((0, 3)) if r1 is None else np.asarray(r1, float),
        branch=np.zeros((0, 3)) if branch is None else np.asarray(branch, float),
        force=np.zeros((0, 3)) if force is None else np.asarray(force, float),
        box=np.array([[0, 0.01], [0, 0.008], [-0.02, 0.04]]) if box is None else box,
        periodic=(True, True, False))


def field(sums, name):
    return sums[cg.SUMS.index(name)]


# ---- kernels -------------------------------------------------------------------------------


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
def test_kernel_is_normalised_and_its_cdf_and_derivative_agree(kernel):
    c = kernel.cutoff
    total, _ = quad(kernel.pdf, -c, c, points=[0.0], epsabs=1e-13)
    assert total == pytest.approx(1.0, abs=1e-10)
    u = np.linspace(-1.2 * c, 1.2 * c, 37)
    for a in u:
        top = min(max(a, -c), c)
        integral, _ = quad(kernel.pdf, -c, top, points=[0.0] if top > 0 else None, epsabs=1e-13)
        assert kernel.cdf(np.array(a)) == pytest.approx(integral, abs=1e-10)
    h = 1e-9
    inside = u[np.abs(u) < 0.95 * c]
    np.testing.assert_allclose(kernel.dpdf(inside), (kernel.pdf(inside + h) - kernel.pdf(inside - h)) / (2 * h),
                               rtol=1e-5, atol=1e-3 * kernel.pdf(0.0) / kernel.width)


def breaks(starts, ends, c):
    """Path parameters where a kernel factor jumps or kinks, for the reference quadrature."""
    out = []
    for u1, u2 in zip(starts, ends):
        for level in (-c, 0.0, c):
            if u2 != u1 and 0 < (level - u1) / (u2 - u1) < 1:
                out.append((level - u1) / (u2 - u1))
    return sorted(out) or None


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
def test_segment_integrals_are_exact(kernel, rng):
    """Closed forms against adaptive quadrature of the definition."""
    c = kernel.cutoff
    for _ in range(25):
        u1, u2 = rng.uniform(-1.5 * c, 1.5 * c, 2)
        expected, _ = quad(lambda t: kernel.pdf(u1 + t * (u2 - u1)), 0, 1, points=breaks([u1], [u2], c),
                           epsabs=1e-12, limit=200)
        assert kernel.segment(np.array(u1), np.array(u2)) == pytest.approx(expected, rel=1e-7, abs=1e-9)
    # Vanishing branch: the point value.
    assert kernel.segment(np.array(0.3 * c), np.array(0.3 * c)) == pytest.approx(float(kernel.pdf(0.3 * c)))
    for _ in range(25):
        a1, b1, a2, b2 = rng.uniform(-1.3 * c, 1.3 * c, 4)
        expected, _ = quad(lambda t: kernel.pdf(a1 + t * (a2 - a1)) * kernel.pdf(b1 + t * (b2 - b1)), 0, 1,
                           points=breaks([a1, b1], [a2, b2], c), epsabs=1e-10, limit=400)
        got = segment_2d(kernel, np.array(a1), np.array(b1), np.array(a2), np.array(b2))
        assert got == pytest.approx(expected, rel=1e-6, abs=1e-6 * float(kernel.pdf(0.0)) ** 2)


# ---- particles -----------------------------------------------------------------------------


def cubic_lattice(a: float, nx: int, ny: int, nz: int) -> np.ndarray:
    i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    return np.column_stack([(i.ravel() + 0.5) * a, (j.ravel() + 0.5) * a, k.ravel() * a])


def test_lattice_gives_its_solid_fraction(rng):
    """Simple cubic lattice, spacing a, radius R: nu = (4/3 pi R^3) / a^3 in the bulk.

    With w = 2 a the kernel's sum over layers ripples by less than 1e-4 (Lucy's Fourier
    transform at the lattice wavenumber), so the pointwise value is within 1e-4; the mean over
    one lattice period is exact.
    """
    a, radius = 1e-3, 0.45e-3
    pos = cubic_lattice(a, 5, 4, 30)
    box = np.array([[0, 5 * a], [0, 4 * a], [0, 30 * a]])
    kernel = Kernel("lucy", 2 * a)
    grid = cg.Grid(np.linspace(12 * a, 13 * a, 201))
    sums = cg.profile_sums(snapshot(pos, np.zeros_like(pos), 1e-6, radius, box=box), kernel, grid)
    nu = field(sums, "volume")
    exact = 4 / 3 * np.pi * radius**3 / a**3
    np.testing.assert_allclose(nu, exact, rtol=1e-4)
    assert np.trapezoid(nu, grid.z) / a == pytest.approx(exact, rel=1e-9)


# w = 8.1 a: no layer sits exactly on the Gaussian cut-off (3 w), where rounding would decide.
@pytest.mark.parametrize("kernel", [Kernel("gaussian", 8.1e-3), Kernel("lucy", 8.1e-3)], ids=lambda k: k.name)
def test_linear_velocity_is_recovered_exactly_in_the_bulk(kernel):
    """v_x = G z + V0 on a lattice of spacing a: at layers and mid-planes (symmetry points, where
    the kernel's first moment over the layers vanishes) u_x = G z + V0 to rounding.

    The shear rate (exact derivative of the coarse-grained u_x) equals G up to the lattice ripple
    of the kernel derivative: Lucy is C2, its ripple is 3e-5 at w = 8.1 a; the Gaussian's
    derivative jumps at the cut (3 w), so its layer sum is a Riemann sum with an O(a / w) error,
    3e-3 here (on a disordered packing that error averages out instead of repeating per layer).
    """
    a, G, V0 = 1e-3, 37.0, 0.2
    pos = cubic_lattice(a, 2, 2, 120)
    vel = np.zeros_like(pos)
    vel[:, 0] = G * pos[:, 2] + V0
    vel[:, 2] = 0.01
    box = np.array([[0, 2 * a], [0, 2 * a], [0, 120 * a]])
    grid = cg.Grid(np.arange(55, 65.01, 0.5) * a)
    sums = cg.profile_sums(snapshot(pos, vel, 2e-6, 0.4e-3, box=box), kernel, grid)
    fields = cg.derive(sums, d=1e-3, rho_s=2500.0)
    np.testing.assert_allclose(fields["u_x"], G * grid.z + V0, rtol=1e-12)
    np.testing.assert_allclose(fields["u_z"], 0.01, rtol=1e-12)
    np.testing.assert_allclose(fields["shear_rate"], G, rtol=1e-4 if kernel.name == "lucy" else 4e-3)
    # The kinetic stress in z is zero: every grain moves at the mean vertical velocity.
    assert np.all(np.abs(fields["sigma_zz_kinetic"]) < 1e-12)


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
def test_mass_is_conserved(kernel, rng):
    """integral of rho dz = sum m / A, for random particles (every kernel support on the grid)."""
    n = 300
    box = np.array([[0, 0.01], [0, 0.008], [0, 0.03]])
    pos = rng.uniform([0, 0, 0.005], [0.01, 0.008, 0.025], (n, 3))
    mass = rng.uniform(1e-6, 2e-6, n)
    grid = cg.Grid(np.linspace(0.0, 0.03, 6001))
    sums = cg.profile_sums(snapshot(pos, rng.normal(size=(n, 3)), mass, 1e-3, box=box), kernel, grid)
    area = 0.01 * 0.008
    # The Gaussian's cut is a jump of pdf(3w) at each end of each particle's support: the
    # trapezoid rule misses at most jump * dz / 2 there, per particle.
    tol = 1e-9 if kernel.name == "lucy" else float(kernel.pdf(np.array(0.999 * kernel.cutoff))) * grid.dz
    assert np.trapezoid(field(sums, "mass"), grid.z) == pytest.approx(mass.sum() / area, rel=tol + 1e-9)
    # and the x-z field conserves mass per unit length in y
    pgrid = cg.plane_grid(0.0, 0.01, 0.0, 0.03, dx=0.01 / 100, bins_z=601)
    psums = cg.plane_sums(snapshot(pos, rng.normal(size=(n, 3)), mass, 1e-3, box=box), kernel, pgrid)
    total = np.trapezoid(field(psums, "mass"), pgrid.z, axis=1).sum() * pgrid.dx
    assert total == pytest.approx(mass.sum() / 0.008, rel=20 * tol + 1e-6)


# ---- contacts ------------------------------------------------------------------------------


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
def test_single_contact_integrates_to_f_r_over_area(kernel, rng):
    """integral of sigma_ab dz = f_a r_b / A; also across the periodic x face (minimum image)."""
    box = np.array([[0, 0.01], [0, 0.008], [0, 0.03]])
    area = 0.01 * 0.008
    f = np.array([[3e-3, -1e-3, -7e-3]])
    for r1, r2 in (([0.004, 0.003, 0.012], [0.0035, 0.0041, 0.0138]),
                   ([0.0003, 0.0079, 0.015], [0.0094, 0.0002, 0.0141])):  # across x and y faces
        r1, r2 = np.array([r1]), np.array([r2])
        branch = r1 - r2
        branch[:, :2] -= box[:2, 1] * np.round(branch[:, :2] / box[:2, 1])
        assert np.all(np.abs(branch) < 0.002)
        grid = cg.Grid(np.linspace(0.0, 0.03, 6001))
        data = snapshot(np.zeros((0, 3)), np.zeros((0, 3)), [], [], r1=r1, branch=branch, force=f, box=box)
        sums = cg.profile_sums(data, kernel, grid)
        tol = 1e-9 if kernel.name == "lucy" else 2e-3
        for name, a, b in (("c_xx", 0, 0), ("c_yy", 1, 1), ("c_zz", 2, 2), ("c_xz", 0, 2), ("c_zx", 2, 0)):
            exact = f[0, a] * branch[0, b] / area
            assert np.trapezoid(field(sums, name), grid.z) == pytest.approx(exact, rel=tol, abs=1e-12)
        # x-z field: the double integral is f r / Ly
        pgrid = cg.plane_grid(0.0, 0.01, 0.0, 0.03, dx=0.01 / 200, bins_z=1201)
        psums = cg.plane_sums(data, kernel, pgrid)
        total = np.trapezoid(field(psums, "c_xz"), pgrid.z, axis=1).sum() * pgrid.dx
        assert total == pytest.approx(f[0, 0] * branch[0, 2] / 0.008, rel=10 * tol + 1e-5)


def test_contact_stress_is_the_force_across_a_plane():
    """Far from the contact's ends (kernel narrow), the stress between two particles is the
    force per area, half of it at an end: a sharp Irving-Kirkwood check of the sign convention
    (compressive positive). The grid is uniform, as the library assumes."""
    box = np.array([[0, 0.01], [0, 0.01], [0, 0.03]])
    kernel = Kernel("gaussian", 1e-5)
    r1, r2 = np.array([[0.005, 0.005, 0.012]]), np.array([[0.005, 0.005, 0.010]])
    f = np.array([[0.0, 0.0, 2e-3]])  # repulsive: on the upper particle, upwards
    grid = cg.Grid(np.array([0.0105, 0.011, 0.0115, 0.012, 0.0125]))
    sums = cg.profile_sums(snapshot(np.zeros((0, 3)), np.zeros((0, 3)), [], [], r1=r1, branch=r1 - r2, force=f,
                                    box=box), kernel, grid)
    np.testing.assert_allclose(field(sums, "c_zz"), [20.0, 20.0, 20.0, 10.0, 0.0], rtol=1e-12, atol=1e-12)


def test_block_errors_and_fields(rng):
    """Block standard errors: B blocks of the same field give std / sqrt(B)."""
    stack = np.ones((10, len(cg.SUMS), 3))
    stack[:, cg.SUMS.index("volume")] = np.arange(10.0)[:, None]
    fields, errors, used = cg.block_average(stack, 5, d=1e-3, rho_s=2500.0)
    assert used == 5
    means = np.array([0.5, 2.5, 4.5, 6.5, 8.5])
    np.testing.assert_allclose(fields["nu"], 4.5)
    np.testing.assert_allclose(errors["nu"], means.std(ddof=1) / np.sqrt(5))


def test_command_line_writes_the_contract_variables(tmp_path, rng):
    """The CLI on a small text dump pair, with generic contact columns."""
    n = 60
    pos = rng.uniform([0, 0, 0], [0.01, 0.01, 0.02], (n, 3))
    with open(tmp_path / "p.dump", "w") as fh, open(tmp_path / "c.dump", "w") as fc:
        for step in range(0, 60, 10):
            fh.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS pp pp ff\n0 0.01\n0 0.01\n"
                     f"0 0.03\nITEM: ATOMS mass radius id z y x vz vy vx type\n")
            for i in range(n):
                v = rng.normal(size=3)
                fh.write(f"1e-5 0.001 {i + 1} {pos[i, 2]} {pos[i, 1]} {pos[i, 0]} {v[2]} {v[1]} {v[0]} 1\n")
            fc.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n2\nITEM: BOX BOUNDS pp pp ff\n0 0.01\n0 0.01\n"
                     f"0 0.03\nITEM: ENTRIES c_a[1] c_a[2] c_a[3] c_a[4] c_a[5] c_a[6] c_a[7] c_a[8] c_a[9] c_a[10] "
                     f"c_a[11] c_a[12]\n")
            for k in range(2):
                p1, p2 = pos[k], pos[k + 1]  # grains k + 1 and k + 2, where the particle dump puts them
                fc.write(" ".join(str(x) for x in [*p1, *p2, k + 1, k + 2, 0, 1e-3, 0, 2e-3]) + "\n")
    out = tmp_path / "f.nc"
    argv = [str(tmp_path / "p.dump"), "--contacts", str(tmp_path / "c.dump"), "--out", str(out), "--width", "0.001",
            "--contact-columns", "x1 y1 z1 x2 y2 z2 id1 id2 periodic fx fy fz"]
    assert dumps_cli.main(argv) == 0
    import xarray as xr

    with xr.open_dataset(out) as ds:
        for name in ("nu", "rho", "u_x", "u_z", "shear_rate", "sigma_xx", "sigma_yy", "sigma_zz", "sigma_xz",
                     "sigma_xz_contact", "sigma_xz_kinetic", "p", "mu", "I"):
            assert ds[name].attrs["units"] and ds[name].attrs["long_name"]
            assert f"{name}_err" in ds
        assert ds.attrs["kernel"] == "gaussian" and ds.attrs["width"] == 0.001
        assert ds.attrs["number_of_snapshots"] == 6
    assert dumps_cli.main(argv[:-2] + ["--plane", "xz", "--dx", "0.001"]) == 0
    with xr.open_dataset(out) as ds:
        assert ds["nu"].dims == ("x", "z")
    assert dumps_cli.main([str(tmp_path / "missing.dump"), "--out", str(out)]) == 1


# ---- optimised path against a straightforward reference ---------------------------------------


def reference_profile_sums(data, kernel, grid):
    """Dense reference for :func:`cg.profile_sums` on a batch: every particle and every contact
    against every grid point, one snapshot at a time, no windows, tables or sparse matrices."""
    z = grid.z
    out = np.zeros((data.nsnap, len(cg.SUMS), z.size))
    for s in range(data.nsnap):
        p, c = data.psid == s, data.csid == s
        u = z[None, :] - data.pos[p, 2][:, None]
        phi, dphi = kernel.pdf(u), kernel.dpdf(u)
        m, v = data.mass[p], data.vel[p]
        weights = {"mass": m, "mass_body": m * data.body[p], "volume": data.volume[p],
                   "mom_x": m * v[:, 0], "mom_y": m * v[:, 1], "mom_z": m * v[:, 2],
                   "mvv_xx": m * v[:, 0] ** 2, "mvv_yy": m * v[:, 1] ** 2, "mvv_zz": m * v[:, 2] ** 2,
                   "mvv_xz": m * v[:, 0] * v[:, 2]}
        for name, wgt in weights.items():
            out[s, cg.SUMS.index(name)] = wgt @ phi
        out[s, cg.SUMS.index("dmass")] = m @ dphi
        out[s, cg.SUMS.index("dmom_x")] = (m * v[:, 0]) @ dphi
        z1 = data.r1[c, 2]
        z2 = z1 - data.branch[c, 2]
        weight = kernel.segment(z[None, :] - z1[:, None], z[None, :] - z2[:, None])
        f, r = data.force[c], data.branch[c]
        for name, a, b in (("c_xx", 0, 0), ("c_yy", 1, 1), ("c_zz", 2, 2), ("c_xz", 0, 2), ("c_zx", 2, 0)):
            out[s, cg.SUMS.index(name)] = (f[:, a] * r[:, b]) @ weight
        out[s] /= data.areas[s]
    return out


def reference_plane_sums(data, kernel, grid):
    """Dense reference for :func:`cg.plane_sums` on a batch: every grid point, the periodic images
    in x summed explicitly (offsets shifted by -lx, 0, +lx)."""
    xg, zg = np.meshgrid(grid.x, grid.z, indexing="ij")
    out = np.zeros((data.nsnap, len(cg.SUMS)) + xg.shape)
    for s in range(data.nsnap):
        lx, ly = data.lengths[s, 0], data.lengths[s, 1]
        p, c = np.nonzero(data.psid == s)[0], np.nonzero(data.csid == s)[0]
        for i in p:
            m, v = data.mass[i], data.vel[i]
            px = sum(kernel.pdf(xg - data.pos[i, 0] + k * lx) for k in (-1, 0, 1))
            uz = zg - data.pos[i, 2]
            phi, dphi = px * kernel.pdf(uz), px * kernel.dpdf(uz)
            for name, wgt in (("mass", m), ("mass_body", m * data.body[i]), ("volume", data.volume[i]),
                              ("mom_x", m * v[0]), ("mom_y", m * v[1]), ("mom_z", m * v[2]),
                              ("mvv_xx", m * v[0] ** 2), ("mvv_yy", m * v[1] ** 2), ("mvv_zz", m * v[2] ** 2),
                              ("mvv_xz", m * v[0] * v[2])):
                out[s, cg.SUMS.index(name)] += wgt * phi
            out[s, cg.SUMS.index("dmass")] += m * dphi
            out[s, cg.SUMS.index("dmom_x")] += m * v[0] * dphi
        for j in c:
            x1, z1 = data.r1[j, 0], data.r1[j, 2]
            x2, z2 = x1 - data.branch[j, 0], z1 - data.branch[j, 2]
            weight = sum(segment_2d(kernel, xg - x1 + k * lx, zg - z1, xg - x2 + k * lx, zg - z2) for k in (-1, 0, 1))
            f, r = data.force[j], data.branch[j]
            for name, a, b in (("c_xx", 0, 0), ("c_yy", 1, 1), ("c_zz", 2, 2), ("c_xz", 0, 2), ("c_zx", 2, 0)):
                out[s, cg.SUMS.index(name)] += f[a] * r[b] * weight
        out[s] /= ly
    return out


def random_batch(rng, nsnap, n, m):
    """A batch of ``nsnap`` random snapshots of ``n`` grains and ``m`` contacts each, in a periodic
    10 x 8 mm cell, grains also below and above the grid; contacts include ones across the periodic
    faces, a horizontal one (branch z = 0, the short-branch path of the profile weight), nearly
    horizontal ones on both sides of ``cg.FLAT_BRANCH`` and a vertical one (branch x = 0)."""
    lengths = np.array([[0.01, 0.008, 0.03]] * nsnap)
    pos = rng.uniform([0, 0, -0.002], [0.01, 0.008, 0.032], (nsnap * n, 3))
    r1 = rng.uniform([0, 0, 0.0], [0.01, 0.008, 0.03], (nsnap * m, 3))
    branch = rng.uniform(-1, 1, (nsnap * m, 3))
    branch *= rng.uniform(0.5e-3, 2.4e-3, (nsnap * m, 1)) / np.linalg.norm(branch, axis=1, keepdims=True)
    branch[0, 2] = 0.0
    branch[1, 0] = 0.0
    branch[3, 2], branch[4, 2], branch[5, 2] = 5e-6, 2e-5, -3e-9  # nearly horizontal: 0.005 w, 0.02 w, 3e-6 w
    r1[2, 0] = 0.0003  # close to the x face: r2 lies across it
    return cg.SnapshotData(
        pos=pos, vel=rng.normal(size=(nsnap * n, 3)), mass=rng.uniform(1e-6, 2e-6, nsnap * n),
        volume=rng.uniform(1e-10, 2e-10, nsnap * n), body=rng.random(nsnap * n) < 0.8,
        r1=r1, branch=branch, force=rng.normal(size=(nsnap * m, 3)) * 1e-3,
        box=np.array([[0, 0.01], [0, 0.008], [0, 0.03]]), periodic=(True, True, False),
        psid=np.repeat(np.arange(nsnap), n), csid=np.repeat(np.arange(nsnap), m),
        areas=lengths[:, 0] * lengths[:, 1], lengths=lengths)


def assert_sums_equal(got, expected, rtol=1e-12):
    """Every sum equal to ``rtol`` relative to that sum's largest magnitude (single bins may be ~0)."""
    assert got.shape == expected.shape
    for k, name in enumerate(cg.SUMS):
        scale = np.abs(expected[:, k]).max()
        assert scale > 0, name
        np.testing.assert_allclose(got[:, k], expected[:, k], rtol=0, atol=rtol * scale, err_msg=name)


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
def test_optimised_profile_equals_the_dense_reference(kernel, rng):
    """Windows, per-height cdf tables, chunking and sparse deposits change nothing: the batch sums
    equal the dense per-snapshot reference to 1e-12 (also with more rows than one chunk)."""
    data = random_batch(rng, 3, 900, 1500)
    grid = cg.Grid(np.linspace(0.001, 0.029, 57))
    expected = reference_profile_sums(data, kernel, grid)
    assert_sums_equal(cg.profile_sums(data, kernel, grid), expected)
    contacts_only = cg.profile_sums(data, kernel, grid, particles=False)
    for k, name in enumerate(cg.SUMS):
        if name.startswith("c_"):
            np.testing.assert_array_equal(contacts_only[:, k], cg.profile_sums(data, kernel, grid)[:, k])
        else:
            assert not contacts_only[:, k].any()
    # Every contact steep and on the grid (the telescoped path alone, nothing pruned).
    steep = cg.SnapshotData(**{**data.__dict__, "branch": data.branch.copy()})
    steep.branch[:, 2] = np.where(data.branch[:, 2] < 0, -1.0, 1.0) * np.maximum(np.abs(data.branch[:, 2]), 5e-4)
    assert_sums_equal(cg.profile_sums(steep, kernel, grid), reference_profile_sums(steep, kernel, grid))
    # A grid touching only part of the contacts (the pruned path), and one snapshot alone.
    narrow = cg.Grid(np.array([0.012, 0.0125]))
    assert_sums_equal(cg.profile_sums(data, kernel, narrow), reference_profile_sums(data, kernel, narrow))
    p, c = data.psid == 0, data.csid == 0
    one = cg.SnapshotData(pos=data.pos[p], vel=data.vel[p], mass=data.mass[p], volume=data.volume[p],
                          body=data.body[p], r1=data.r1[c], branch=data.branch[c], force=data.force[c],
                          box=data.box, periodic=data.periodic)
    assert_sums_equal(cg.profile_sums(one, kernel, grid)[None], expected[:1])


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.name)
def test_optimised_plane_equals_the_dense_reference(kernel, rng, monkeypatch):
    """x-z sums of a batch (all snapshots in one pass, chunked contacts) against the dense reference
    with explicit periodic images and the exact line integral: every contact exact
    (``exact=True``) equals it to 1e-12; with the pipeline's rule the particle sums still do,
    and the contact sums agree to 2e-3 of their largest magnitude. Why 2e-3: on branches up to the
    rule's 2.5 kernel widths the 8-point rule's error is at most 4e-4 of one contact's peak weight
    (its kinks at the cut-off; docs/dem_cost.md 33), and a sum's largest bin is at least one
    contact's peak. The branches here reach 2.4 w: all by the rule, then (``LONG_BRANCH = 1.5``)
    about half of them exactly, the two kinds of contact in one pass."""
    data = random_batch(rng, 2, 40, 25)
    grid = cg.plane_grid(0.0, 0.01, 0.001, 0.029, dx=0.7e-3)
    expected = reference_plane_sums(data, kernel, grid)
    contacts = [k for k, name in enumerate(cg.SUMS) if name.startswith("c_")]
    others = [k for k in range(len(cg.SUMS)) if k not in contacts]
    got, rule = {0.0: cg.plane_sums(data, kernel, grid, exact=True)}, plane.LONG_BRANCH
    for long_branch in (rule, 1.5):
        monkeypatch.setattr(plane, "LONG_BRANCH", long_branch)
        got[long_branch] = cg.plane_sums(data, kernel, grid)
    assert_sums_equal(got[0.0], expected)
    for long_branch in (rule, 1.5):
        np.testing.assert_array_equal(got[long_branch][:, others], got[0.0][:, others])
        worst = max(float(np.abs(got[long_branch][:, k] - expected[:, k]).max() / np.abs(expected[:, k]).max())
                    for k in contacts)
        assert 0.0 < worst < 2e-3, long_branch  # not exact (the rule ran), and within its bound


def test_segment_with_tabulated_cdf_is_the_same(rng):
    kernel = KERNELS[0]
    u1, u2 = rng.uniform(-4e-3, 4e-3, (2, 50, 7))
    u2[0, 0] = u1[0, 0]  # a short branch
    np.testing.assert_array_equal(kernel.segment(u1, u2, kernel.cdf(u1), kernel.cdf(u2)), kernel.segment(u1, u2))


def test_integrated_autocorrelation_time_of_known_processes(rng):
    from pipeline.common.statistics import integrated_autocorrelation_time
    # White noise: tau = 1/2. AR(1) with coefficient phi: tau = (1 + phi) / (2 (1 - phi)).
    white = rng.standard_normal((20000, 2))
    assert np.allclose(integrated_autocorrelation_time(white), 0.5, atol=0.05)
    phi = 0.8
    x = np.zeros((20000, 2))
    noise = rng.standard_normal(x.shape)
    for t in range(1, x.shape[0]):
        x[t] = phi * x[t - 1] + noise[t]
    assert np.allclose(integrated_autocorrelation_time(x), (1 + phi) / (2 * (1 - phi)), rtol=0.15)
