"""Light is conserved (``illumap.conservation``): every transport row sums to the share of its
surfel's hemisphere that meets a surface, never more, and exact furnaces stay exact.

The bounds are what a correct method meets, not what the code gives: the balance's closing
step makes ``rows ≤ hits`` exact (1e-9 is rounding); a closed furnace with rows of exactly 1
has ``B (1 − ρ) = E`` up to the solver's tolerance and the Sinkhorn iteration's residual;
the sphere's closed form counts each surfel's own area out of its row (``1 − a_i``), which a
hemisphere share of 1 does not, so a correct method differs from it by ρ a_i/(1 − ρ): 0.16%
at 12,000 surfels and ρ 0.95.
"""

import numpy as np
import pytest

import illumap
from illumap import conservation, scenes
from illumap.receivers import MeshOccluders
from illumap_core_testing import requires_native

pytestmark = requires_native


def _a_inner(op, areas, x, y):
    """x · diag(A) K y for single columns."""
    return float(np.sum(x * areas * op.apply(np.repeat(y[:, None], 3, axis=1))[:, 0]))


@pytest.mark.parametrize("sampling", ["grid", "random"])
def test_each_row_is_its_share(sampling):
    """Rows scaled one by one (the default) sum to their share exactly, and the operator is
    then not reciprocal: the solve takes GMRES."""
    s = scenes.closed_box(10, sampling=sampling, seed=3)
    rng = np.random.default_rng(1)
    hits = rng.uniform(0.2, 0.6, s.n)
    op = illumap.TransportOperator(s, hemisphere_hits=hits)
    rows = op.apply(np.ones((s.n, 3)))[:, 0]
    assert np.allclose(rows, hits, rtol=1e-9, atol=0)
    assert op.stats["balance_max_row_after"] <= hits.max() * (1 + 1e-12)
    assert not op.symmetric
    assert illumap.solve(s, operator=op).stats["solver"] == "gmres"


@pytest.mark.parametrize("balance", ["rows", "symmetric"])
def test_rows_keep_within_a_band(balance):
    """With a bound above the share, rows already inside [hits, bound] keep their sum and
    the others are brought to its nearer end."""
    s = scenes.closed_box(10, sampling="random", seed=3)
    bare = illumap.TransportOperator(s).apply(np.ones((s.n, 3)))[:, 0]
    hits, bound = np.full(s.n, 0.9), np.full(s.n, 0.98)
    op = illumap.TransportOperator(s, hemisphere_hits=hits, hemisphere_bound=bound,
                                   hemisphere_balance=balance)
    rows = op.apply(np.ones((s.n, 3)))[:, 0]
    assert np.all(rows <= bound + 1e-9)
    inside = (bare >= 0.9) & (bare <= 0.98)
    assert inside.any() and (~inside).any()
    if balance == "rows":
        assert np.allclose(rows[inside], bare[inside], rtol=1e-12)
        assert np.allclose(rows[~inside], np.clip(bare[~inside], 0.9, 0.98), rtol=1e-9)
    else:
        assert np.all(rows >= hits - 1e-3)


@pytest.mark.parametrize("sampling", ["grid", "random"])
def test_rows_never_exceed_the_hemisphere(sampling):
    """Scaled symmetrically, a share below the kernel's rows (half the hemisphere) lowers
    every row to at most it, and the operator stays reciprocal (diag(A) K' symmetric), so CG
    still applies."""
    s = scenes.closed_box(10, sampling=sampling, seed=3)
    rng = np.random.default_rng(1)
    hits = rng.uniform(0.2, 0.6, s.n)
    op = illumap.TransportOperator(s, hemisphere_hits=hits, hemisphere_balance="symmetric")
    rows = op.apply(np.ones((s.n, 3)))[:, 0]
    assert np.all(rows <= hits + 1e-9)
    assert op.stats["balance_max_row_after"] <= hits.max() + 1e-9
    x, y = rng.random(s.n), rng.random(s.n)
    lhs, rhs = _a_inner(op, s.areas, x, y), _a_inner(op, s.areas, y, x)
    assert abs(lhs - rhs) <= 1e-9 * abs(lhs)
    assert op.symmetric


def test_a_sealed_surfel_neither_receives_nor_sends():
    """A share of 0 (a surfel buried inside a closed part) zeroes its row and its column."""
    s = scenes.closed_box(6)
    hits = np.ones(s.n)
    hits[5] = 0.0
    op = illumap.TransportOperator(s, hemisphere_hits=hits, hemisphere_balance="symmetric")
    e = np.zeros((s.n, 3))
    e[5] = 1.0
    assert np.all(op.apply(e) == 0.0)
    assert np.all(op.apply(np.ones((s.n, 3)))[5] == 0.0)


@pytest.mark.parametrize("balance", ["rows", "symmetric"])
@pytest.mark.parametrize("rho", [0.9, 0.99])
@pytest.mark.parametrize("sampling", ["grid", "random"])
def test_closed_furnace_is_exact_at_every_surfel(rho, sampling, balance):
    """Uniform E and ρ inside a closed box: B = E/(1 − ρ) at every surfel, however the
    surfels are jittered. The kernel's own rows (0.95-1.08 on the random box) put single
    surfels tens of percent off at ρ 0.99 (the issue's target: at most 1%). Rows scaled one
    by one sum to 1 to rounding, so B (1 − ρ) is 1 to the solver's tolerance amplified by
    1/(1 − ρ) (1e-8 at ρ 0.99; 1e-6 asserted); the symmetric balance leaves each row within
    BALANCE_TOL of 1, which ρ/(1 − ρ) amplifies (0.01% at ρ 0.99)."""
    from illumap.conservation import BALANCE_TOL
    s = scenes.closed_box(16, sampling=sampling, albedo=rho, emission=1.0, seed=5)
    bare = illumap.solve(s, tol=1e-10)
    sol = illumap.solve(s, tol=1e-10, hemisphere_hits=np.ones(s.n), hemisphere_balance=balance)
    assert sol.converged and sol.stats["solver"] == ("cg" if balance == "symmetric" else "gmres")
    worst = float(np.max(np.abs(sol.radiosity * (1 - rho) - 1.0)))
    worst_bare = float(np.max(np.abs(bare.radiosity * (1 - rho) - 1.0)))
    print(f"\n{sampling} rho {rho} {balance}: worst surfel {worst:.4%} (kernel's rows: {worst_bare:.2%})")
    bound = 1e-6 if balance == "rows" else BALANCE_TOL * rho / (1 - rho) + 1e-6
    assert worst <= bound


@pytest.mark.parametrize("balance", ["rows", "symmetric"])
@pytest.mark.parametrize("sampling, areas", [("fibonacci", "uniform"), ("random", "random")])
def test_sphere_at_default_settings(sampling, areas, balance):
    """The sphere's closed form at ρ 0.95 with the default FMM and near field: within 0.2%
    once the rows follow the hemisphere (1.7-2.1% on the kernel's own rows). The closed form
    counts each surfel's own area out of its row (1 − a_i) and a hemisphere share of 1 does
    not: ``conserving_sphere_radiosity`` is the closed form of the operator a correct
    conserving method builds (each row the others' areas over theirs), which the default FMM
    must meet to its expansion error (``illumap.accuracy.FMM_ERROR`` at the default order and
    θ, p 3 and 0.5: 6.9e-3; measured 3-4e-5), and the direct sum to the disc rule's change of the closest pairs (1e-4 at
    12,000 surfels, whose a_i is 8e-5)."""
    from illumap.accuracy import FMM_ERROR
    from illumap.operator import DEFAULT_ORDER, DEFAULT_THETA
    s = scenes.sphere_interior(12000, radius=1.0, sampling=sampling, areas=areas, albedo=0.95,
                               seed=7)
    exact = scenes.sphere_exact_radiosity(s, 1.0)
    conserving = conserving_sphere_radiosity(s, 1.0)
    sol = illumap.solve(s, tol=1e-9, hemisphere_hits=np.ones(s.n), hemisphere_balance=balance)
    err = np.linalg.norm(sol.radiosity - exact) / np.linalg.norm(exact)
    own = np.linalg.norm(sol.radiosity - conserving) / np.linalg.norm(conserving)
    print(f"\n{sampling} {balance}: closed form {err:.3%}, conserving closed form {own:.2e}")
    assert sol.converged
    assert err <= 0.002, err
    assert own <= FMM_ERROR[DEFAULT_THETA][DEFAULT_ORDER], own
    direct = illumap.solve(s, method="direct", tol=1e-10, hemisphere_hits=np.ones(s.n),
                           hemisphere_balance=balance)
    own_direct = np.linalg.norm(direct.radiosity - conserving) / np.linalg.norm(conserving)
    assert own_direct <= 1e-4, own_direct


def conserving_sphere_radiosity(surfels, radius: float) -> np.ndarray:
    """The exact solution inside a sphere of the operator whose rows are the point kernel's
    scaled to 1: ``K_ij = a_j / (t − a_i)`` for j ≠ i (a_i = A_i/(4πR²), t = Σ a). With
    ``c_i = ρ_i/(t − a_i)`` and S = Σ a_j B_j: ``B_i = (E_i + c_i S)/(1 + c_i a_i)``,
    ``S = Σ a_i E_i/(1 + c_i a_i) / (1 − Σ a_i c_i/(1 + c_i a_i))``."""
    a = surfels.areas[:, None] / (4.0 * np.pi * radius ** 2)
    c = surfels.albedo / (a.sum() - a)
    d = 1.0 + c * a
    S = (a * surfels.emission / d).sum(axis=0) / (1.0 - (a * c / d).sum(axis=0))
    return (surfels.emission + c * S) / d


def test_balance_reports_bad_shares():
    s = scenes.closed_box(4)
    with pytest.raises(illumap.InputError, match=r"hemisphere_hits\[3\]"):
        illumap.TransportOperator(s, hemisphere_hits=np.r_[np.ones(3), 1.5, np.ones(s.n - 4)])
    with pytest.raises(illumap.InputError, match="one per surfel"):
        illumap.TransportOperator(s, hemisphere_hits=np.ones(s.n - 1))


# ---- the share itself, measured by rays -----------------------------------------------------

def _square(z, size=1.0, down=True):
    """Two triangles of a square of side ``size`` centred over the origin at height z, facing
    down (toward the origin) or up."""
    h = size / 2
    a, b, c, d = (-h, -h, z), (h, -h, z), (h, h, z), (-h, h, z)
    tris = [[a, c, b], [a, d, c]] if down else [[a, b, c], [a, c, d]]
    return np.array(tris, dtype=np.float64)


def _surfels_on(tris, per_side=8, normal=(0, 0, -1)):
    """A grid of points on the square the triangles make, with ``normal``."""
    lo, hi = tris.reshape(-1, 3).min(0), tris.reshape(-1, 3).max(0)
    u = (np.arange(per_side) + 0.5) / per_side
    x, y = np.meshgrid(lo[0] + u * (hi[0] - lo[0]), lo[1] + u * (hi[1] - lo[1]))
    p = np.c_[x.ravel(), y.ravel(), np.full(x.size, lo[2])]
    return p, np.tile(np.asarray(normal, float), (len(p), 1))


def test_share_of_a_square_overhead():
    """A point under a centred unit square at height 1 sees it with form factor 0.23945: that
    share hits, the rest is open (sky)."""
    square = _square(1.0)
    sp, sn = _surfels_on(square)
    receiver = np.array([[0.0, 0.0, 0.0]])
    occ = MeshOccluders(square)
    pos = np.r_[receiver, sp]
    nrm = np.r_[[[0.0, 0.0, 1.0]], sn]
    got = conservation.hemisphere_hits(occ, pos, nrm, rays=4096)
    assert abs(got.hits[0] - 0.23945) <= 0.005
    assert abs(got.open[0] - (1 - 0.23945)) <= 0.005
    assert got.hits[1:].max() == 0.0 and np.all(got.open[1:] == 1.0)   # they face away


def test_share_of_a_face_without_surfels_is_dark():
    """The same square seen from its back, where no surfel lies (the inside of a closed
    part): nothing hits and nothing is open. Lit on both faces (a splat), it hits."""
    square = _square(1.0, down=False)            # faces up: the receiver sees its back
    sp, sn = _surfels_on(square, normal=(0, 0, 1))
    occ = MeshOccluders(square)
    pos = np.r_[[[0.0, 0.0, 0.0]], sp]
    nrm = np.r_[[[0.0, 0.0, 1.0]], sn]
    got = conservation.hemisphere_hits(occ, pos, nrm, rays=4096, lit_backs=np.zeros(2, bool))
    assert got.hits[0] == 0.0
    assert abs(got.open[0] - (1 - 0.23945)) <= 0.005
    lit = conservation.hemisphere_hits(occ, pos, nrm, rays=4096)     # a splat: both faces lit
    assert abs(lit.hits[0] - 0.23945) <= 0.005


# ---- the share a kernel row cannot reach: its rays' first hits ------------------------------

def _box_triangles(lo, hi, inward):
    """The 12 triangles of an axis-aligned box, their fronts facing in or out."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    c = np.array([[x, y, z] for z in (lo[2], hi[2]) for y in (lo[1], hi[1]) for x in (lo[0], hi[0])])
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = []
    for a, b, cc, d in quads:                  # each quad's front faces out of the box
        t1, t2 = [c[a], c[b], c[cc]], [c[a], c[cc], c[d]]
        tris += [t1[::-1], t2[::-1]] if inward else [t1, t2]
    return np.array(tris)


def test_a_fill_takes_the_surfels_its_rays_meet():
    """Two unit squares facing each other at distance 1: the kernel's row is F = 0.1998, which
    (0.16-0.19 point by point) MAX_SCALE (3) cannot raise to a share of 0.9. The rest comes from the first hits of
    the row's own rays, all on the other square, so every row sums to its share exactly;
    without the fill the rows stop at 3 F (0.47-0.58)."""
    s, a, b = scenes.parallel_squares(8)
    tris = np.r_[_square(0.0, down=False) + [0.5, 0.5, 0.0], _square(1.0) + [0.5, 0.5, 0.0]]
    hits = np.full(s.n, 0.9)
    op = illumap.TransportOperator(s, method="direct", hemisphere_hits=hits,
                                   occluder_triangles=tris)
    rows = op.apply(np.ones((s.n, 3)))[:, 0]
    assert np.allclose(rows, hits, rtol=1e-12, atol=0)
    assert op.stats["hemisphere_fill_rows"] == s.n
    fill = op.fill
    assert np.all(a[fill.rows] != a[fill.cols])            # each hit on the other square
    plain = illumap.TransportOperator(s, method="direct", hemisphere_hits=hits,
                                      occluder_triangles=tris, hemisphere_fill=False)
    bare = illumap.TransportOperator(s, method="direct").apply(np.ones((s.n, 3)))[:, 0]
    assert np.allclose(plain.apply(np.ones((s.n, 3)))[:, 0], 3 * bare, rtol=1e-12)
    assert bare.max() * 3 < 0.9 and plain.fill is None


def test_a_fill_cast_against_the_callers_ray_scene_is_the_same():
    """The fill against the caller's ray scene of the same triangles (``occluders=``, the
    gather's, which the run shares) gives the same entries, bit for bit, as against the one
    it builds itself; a ray scene of other triangles is not taken."""
    s, a, b = scenes.parallel_squares(8)
    tris = np.r_[_square(0.0, down=False) + [0.5, 0.5, 0.0], _square(1.0) + [0.5, 0.5, 0.0]]
    hits = np.full(s.n, 0.9)
    own = illumap.TransportOperator(s, method="direct", hemisphere_hits=hits,
                                    occluder_triangles=tris)
    shared = illumap.TransportOperator(s, method="direct", hemisphere_hits=hits,
                                       occluder_triangles=tris, occluders=MeshOccluders(tris))
    other = illumap.TransportOperator(s, method="direct", hemisphere_hits=hits,
                                      occluder_triangles=tris, occluders=MeshOccluders(tris[:2]))
    for op in (shared, other):
        assert np.array_equal(op.fill.rows, own.fill.rows)
        assert np.array_equal(op.fill.cols, own.fill.cols)
        assert np.array_equal(op.fill.weights, own.fill.weights)
    assert own.fill.cols.size > 0 and np.all(a[own.fill.rows] != a[own.fill.cols])


def test_a_fill_never_takes_a_lit_surfel_across_a_wall():
    """A surfel sealed inside a closed box whose walls lie 2 cm inside a room's: its rays meet
    the box's back faces, which no surfel faces, and the room's surfels that face the same way
    lie just across the wall. The fill gives the sealed surfel nothing; a surfel in the room
    gets its share from the room's own surfels."""
    room = _box_triangles((-1, -1, -1), (1, 1, 1), inward=True)
    box = _box_triangles((-0.98, -0.98, -0.98), (0.98, 0.98, 0.98), inward=False)
    occ = MeshOccluders(np.r_[room, box])
    rng = np.random.default_rng(4)
    faces = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            p = rng.uniform(-0.95, 0.95, (300, 3))
            p[:, axis] = sign
            n = np.zeros((300, 3))
            n[:, axis] = -sign                          # the room's walls face in
            faces.append((p, n))
    p = np.concatenate([f[0] for f in faces])
    n = np.concatenate([f[1] for f in faces])
    inside = np.array([[0.0, 0.0, 0.0]])                # sealed in the box, facing +z
    pos = np.r_[inside, p]
    nrm = np.r_[[[0.0, 0.0, 1.0]], n]
    fill = conservation.first_hit_fill(occ, pos, nrm, np.array([0]), np.array([1.0]))
    assert fill.filled == 0 and len(fill.rows) == 0
    # Between the walls (in the 2 cm gap, facing the room's +x wall) the room is seen.
    gap = np.r_[pos, [[0.99, 0.0, 0.0]]]
    gap_n = np.r_[nrm, [[1.0, 0.0, 0.0]]]
    fill = conservation.first_hit_fill(occ, gap, gap_n, np.array([len(gap) - 1]), np.array([1.0]))
    assert fill.filled == 1 and abs(fill.weights.sum() - 1.0) <= 1e-12
    assert np.all(gap[fill.cols, 0] == 1.0)             # the room's +x wall only
