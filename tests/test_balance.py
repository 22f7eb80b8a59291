"""Tests of pik_mj.balance against brute force, analytic cases and an independent LP.

The independent LP (:func:`corner_lp_feasible`) models each rectangular contact as
forces at its four corners, each a non-negative combination of the four edge rays
of the friction pyramid. It never calls ``wrench_constraints``.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, Delaunay

from pik_mj.balance import (
    ContactConstraint,
    ExternalWrench,
    HalfPlanes,
    contact_from_normal,
    convex_hull_2d,
    foot_contact,
    halfplanes_from_polygon,
    hull_region,
    plane_basis,
    polygon_area,
    polygon_from_halfplanes,
    scfr,
    shrink,
    signed_distance,
    static_equilibrium,
    support_polygon,
    wrench_constraints,
)
from pik_mj.exceptions import InvalidInput

G = 9.81
MASS = 50.0


# ----------------------------------------------------------------------------
# Brute-force / independent helpers
# ----------------------------------------------------------------------------


def cross2(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    t = np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * ab)))


def boundary_distance(p: np.ndarray, poly: np.ndarray) -> float:
    """Euclidean distance of ``p`` to the boundary of a closed polygon."""
    return min(segment_distance(p, poly[i], poly[(i + 1) % len(poly)]) for i in range(len(poly)))


def rot_z(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q


def corner_generators(contact: ContactConstraint) -> tuple[np.ndarray, np.ndarray]:
    """World corner points (k, 3) and world unit-normal pyramid rays (4, 3)."""
    X, Y = contact.half_x, contact.half_y
    local = np.array([[X, Y, 0.0], [-X, Y, 0.0], [-X, -Y, 0.0], [X, -Y, 0.0]])
    R = np.asarray(contact.R_WC)
    corners = np.asarray(contact.p_WC) + local @ R.T
    mu = contact.mu / math.sqrt(2.0)  # inscribed pyramid |fx|,|fy| <= mu fz / sqrt 2
    rays_local = np.array([[mu, mu, 1.0], [mu, -mu, 1.0], [-mu, mu, 1.0], [-mu, -mu, 1.0]])
    return corners, rays_local @ R.T


class CornerLP:
    """Independent equilibrium LP: corner forces = sums of pyramid rays (lambda >= 0).

    Columns: for every contact, corner and ray, the wrench about the world origin
    ``[r ; q x r]`` of a unit-normal ray ``r`` at corner ``q``. Rows:
    ``sum lambda col + w_gravity(c) + w_ext = 0``; per contact
    ``fz_min <= sum lambda <= fz_max`` (each ray has unit normal component).
    """

    def __init__(self, contacts, mass, external=(), gravity=(0.0, 0.0, -G)):
        cols, owner = [], []
        for i, c in enumerate(contacts):
            corners, rays = corner_generators(c)
            for q in corners:
                for r in rays:
                    cols.append(np.concatenate([r, np.cross(q, r)]))
                    owner.append(i)
        self.A_eq = np.array(cols).T
        owner = np.array(owner)
        rows, b = [], []
        for i, c in enumerate(contacts):
            sel = (owner == i).astype(float)
            rows.append(-sel)
            b.append(-c.fz_min)
            if math.isfinite(c.fz_max):
                rows.append(sel)
                b.append(c.fz_max)
        self.A_ub, self.b_ub = np.array(rows), np.array(b)
        self.mass = mass
        self.g = np.asarray(gravity, dtype=float)
        self.w_ext = np.zeros(6)
        for e in external:
            f = np.asarray(e.force, float)
            self.w_ext += np.concatenate([f, np.asarray(e.moment, float) + np.cross(e.p_W, f)])

    def feasible(self, com) -> bool:
        com = np.asarray(com, float)
        w_grav = np.concatenate([self.mass * self.g, np.cross(com, self.mass * self.g)])
        res = linprog(
            np.zeros(self.A_eq.shape[1]),
            A_ub=self.A_ub,
            b_ub=self.b_ub,
            A_eq=self.A_eq,
            b_eq=-(w_grav + self.w_ext),
            bounds=(0.0, None),
            method="highs",
        )
        assert res.status in (0, 2), res.message
        return res.status == 0


def polygon_gap(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Max distance of a's vertices to b's boundary and of b's vertices to a's."""
    return (
        max(boundary_distance(p, b) for p in a),
        max(boundary_distance(p, a) for p in b),
    )


# Non-trivial flat feet: staggered and yawed soles 0.22 x 0.12.
FEET_POSES = [((0.05, 0.1, 0.0), 0.2), ((-0.04, -0.1, 0.0), -0.1)]


def flat_feet(mu: float, fz_max: float = math.inf) -> list[ContactConstraint]:
    return [foot_contact(p, yaw, 0.11, 0.06, mu, fz_max) for p, yaw in FEET_POSES]


def feet_hull(feet: list[ContactConstraint]) -> np.ndarray:
    corners = []
    for c in feet:  # computed here, not with ContactConstraint.corners()
        for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
            corners.append(c.p_WC + c.R_WC @ np.array([sx * c.half_x, sy * c.half_y, 0]))
    pts = np.array(corners)[:, :2]
    return pts[ConvexHull(pts).vertices]  # scipy: counter-clockwise in 2-D


def wall_scenario(hand_mu: float = 0.5) -> list[ContactConstraint]:
    """Low-friction feet (mu = 0.2) and a hand on a wall at x = 0.45 (normal -x)."""
    hand = contact_from_normal(
        [0.45, -0.2, 1.0], [-1.0, 0.0, 0.0], 0.02, 0.02, hand_mu, fz_max=100.0
    )
    return [*flat_feet(0.2), hand]


# ----------------------------------------------------------------------------
# 1-2. Hull, half-planes, signed distance
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(5))
def test_hull_matches_brute_force_and_scipy(seed):
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(60, 2)) * [0.3, 0.1]
    if seed >= 3:  # grids: many collinear and duplicate points
        g = np.arange(5) * 0.1
        pts = np.vstack([np.array([(x, y) for x in g for y in g]), pts[:5] * 0.0])
    hull = convex_hull_2d(pts)
    # ccw, strictly convex (no collinear vertices), no duplicates
    n = len(hull)
    turns = [
        cross2(hull[(i + 1) % n] - hull[i], hull[(i + 2) % n] - hull[(i + 1) % n]) for i in range(n)
    ]
    assert min(turns) > 1e-12
    assert polygon_area(hull) > 0
    # every hull vertex is an input point
    for v in hull:
        assert np.min(np.linalg.norm(pts - v, axis=1)) == 0.0
    # every input point inside or on the hull (brute-force edge tests)
    for p in pts:
        for i in range(n):
            e = hull[(i + 1) % n] - hull[i]
            assert cross2(e, p - hull[i]) >= -1e-12
    ref = ConvexHull(pts)
    assert polygon_area(hull) == pytest.approx(ref.volume, rel=1e-12)
    if seed >= 3:
        assert len(hull) == 4  # the square grid: only its 4 corners


@pytest.mark.parametrize("seed", range(3))
def test_hull_region_is_hull_halfplanes_and_area(seed):
    """hull_region's three results are convex_hull_2d's vertices (sorted-unique
    start as np.unique), halfplanes_from_polygon's and polygon_area's, bit for bit;
    degenerate sets give no half-planes."""
    rng = np.random.default_rng(seed)
    for pts in (rng.normal(size=(9, 2)), np.round(rng.normal(size=(30, 2)), 1)):
        hull, hp, area = hull_region(pts, tol=1e-6)
        assert np.array_equal(hull, convex_hull_2d(pts, tol=1e-6))
        ref = halfplanes_from_polygon(hull)
        assert np.array_equal(hp.A, ref.A) and np.array_equal(hp.b, ref.b)
        assert area == polygon_area(hull) == pytest.approx(ConvexHull(pts).volume, rel=1e-12)
        # the hull starts at the lexicographically smallest point, as np.unique sorts
        assert np.array_equal(hull[0], np.unique(pts, axis=0)[0])
    segment = np.array([[0.0, 0.0], [1.0, 1.0], [0.5, 0.5], [1.0, 1.0]])
    hull, hp, area = hull_region(segment, allow_degenerate=True)
    assert hp is None and area == 0.0
    assert np.array_equal(np.sort(hull, axis=0), [[0.0, 0.0], [1.0, 1.0]])
    with pytest.raises(InvalidInput, match="span no area"):
        hull_region(segment)


def test_signed_distance_vs_brute_force():
    rng = np.random.default_rng(7)
    poly = convex_hull_2d(rng.normal(size=(12, 2)))
    hp = halfplanes_from_polygon(poly)
    assert np.allclose(np.linalg.norm(hp.A, axis=1), 1.0)
    tri = Delaunay(poly)
    n_in = n_out_exact = 0
    for p in rng.uniform(-3, 3, size=(800, 2)):
        sd = signed_distance(hp, p)
        d = boundary_distance(p, poly)
        if tri.find_simplex(p) >= 0:  # inside: exact Euclidean distance
            n_in += 1
            assert sd == pytest.approx(d, abs=1e-12)
        else:  # outside: largest violation, never more than the distance
            assert sd < 0
            assert -sd <= d + 1e-12
            # exact where the nearest boundary point is inside an edge
            k = int(np.argmax(-(hp.A @ p + hp.b)))
            a, b = poly[k], poly[(k + 1) % len(poly)]
            t = np.dot(p - a, b - a) / np.dot(b - a, b - a)
            if 0.0 < t < 1.0 and segment_distance(p, a, b) == pytest.approx(d):
                n_out_exact += 1
                assert -sd == pytest.approx(d, abs=1e-12)
    assert n_in > 50 and n_out_exact > 50


def test_halfplane_round_trip_and_shrink():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    hp = halfplanes_from_polygon(square)
    back = polygon_from_halfplanes(hp)
    assert polygon_area(back) == pytest.approx(1.0)
    assert polygon_gap(back, square) == pytest.approx((0.0, 0.0), abs=1e-12)
    small = polygon_from_halfplanes(shrink(hp, 0.1))
    assert polygon_area(small) == pytest.approx(0.8**2)
    assert signed_distance(shrink(hp, 0.1), [0.5, 0.5]) == pytest.approx(0.4)
    with pytest.raises(InvalidInput, match="empty"):
        polygon_from_halfplanes(shrink(hp, 0.6))
    with pytest.raises(InvalidInput, match="unbounded"):
        polygon_from_halfplanes(HalfPlanes(hp.A[:2], hp.b[:2]))
    with pytest.raises(InvalidInput, match="counter-clockwise"):
        halfplanes_from_polygon(square[::-1])


def test_support_polygon_tilted_normal():
    rng = np.random.default_rng(3)
    n = np.array([0.2, -0.3, 1.0])
    R = plane_basis(n)
    assert np.allclose(R.T @ R, np.eye(3)) and np.linalg.det(R) == pytest.approx(1.0)
    assert np.allclose(R[:, 2], n / np.linalg.norm(n))
    x_proj = np.array([1.0, 0, 0]) - R[0, 2] * R[:, 2]  # world x projected
    assert np.allclose(R[:, 0], x_proj / np.linalg.norm(x_proj))
    polys = [rng.normal(size=(4, 3)) * 0.2 + [0, y, 0] for y in (0.2, -0.2)]
    sp = support_polygon(polys, normal=n)
    pts = np.vstack(polys)
    uv = np.column_stack([pts @ R[:, 0], pts @ R[:, 1]])
    assert sp.area == pytest.approx(ConvexHull(uv).volume, rel=1e-12)
    assert np.allclose(sp.vertices_3d @ R[:, 2], sp.height)
    for v2, v3 in zip(sp.vertices_2d, sp.vertices_3d, strict=True):
        assert np.allclose(sp.to_plane(v3), v2)
    # a point moved along the normal keeps its distance
    c = sp.from_plane(sp.vertices_2d.mean(axis=0))
    assert sp.signed_distance(c + 3.0 * R[:, 2]) == pytest.approx(sp.signed_distance(c))
    assert sp.signed_distance(c) > 0


# ----------------------------------------------------------------------------
# Contact wrench limits vs the corner-force model
# ----------------------------------------------------------------------------


def test_wrench_constraints_equal_corner_cone():
    """C w + d >= 0 holds exactly for the wrenches four corner forces can make."""
    rng = np.random.default_rng(11)
    R = random_rotation(rng)
    contact = ContactConstraint(p_WC=[0.3, -0.2, 0.5], R_WC=R, half_x=0.11, half_y=0.06, mu=0.7)
    C, d = wrench_constraints(contact)
    corners, rays = corner_generators(contact)
    p = np.asarray(contact.p_WC)
    cols = np.array(
        [np.concatenate([r, np.cross(q - p, r)]) for q in corners for r in rays]
    ).T  # wrench about p_WC, world frame
    # soundness: random corner combinations satisfy the rows
    lam = rng.exponential(size=(cols.shape[1], 2000)) * (rng.random((16, 2000)) < 0.4)
    W = cols @ lam
    assert np.min(C @ W + d[:, None]) > -1e-9
    # completeness: perturbed wrenches are inside iff a corner decomposition exists
    agree = inside = outside = 0
    for k in range(400):
        w = W[:, k] + rng.normal(size=6) * [5, 5, 5, 0.5, 0.5, 0.5] * 0.3
        margin = float(np.min(C @ w + d))
        if abs(margin) < 1e-7:
            continue
        res = linprog(np.zeros(16), A_eq=cols, b_eq=w, bounds=(0.0, None), method="highs")
        assert res.status in (0, 2)
        assert (res.status == 0) == (margin > 0), (k, margin, w)
        agree += 1
        inside += margin > 0
        outside += margin < 0
    assert inside > 40 and outside > 40, (inside, outside)


def test_wrench_constraints_limits_without_torsion_and_bounds():
    c = foot_contact([0, 0, 0], 0.0, 0.1, 0.05, 0.5, fz_max=300.0, torsion=False)
    C, d = wrench_constraints(c)
    ok = np.array([0.0, 0.0, 100.0, 4.9, -9.9, 1e3])  # free yaw moment
    assert np.min(C @ ok + d) >= 0
    mu_in = 0.5 / math.sqrt(2)
    for w in (
        [mu_in * 100 * 1.01, 0, 100, 0, 0, 0],  # friction (inscribed pyramid)
        [0, 0, 100, 5.1, 0, 0],  # CoP beyond half_y
        [0, 0, 100, 0, 10.1, 0],  # CoP beyond half_x
        [0, 0, 301, 0, 0, 0],  # fz_max
        [0, 0, -1, 0, 0, 0],  # pulling
    ):
        assert np.min(C @ np.array(w) + d) < 0, w
    circ = foot_contact([0, 0, 0], 0, 0.1, 0.05, 0.5, pyramid="circumscribed")
    Cc, dc = wrench_constraints(circ)
    assert np.min(Cc @ np.array([0.5 * 100, 0, 100, 0, 0, 0]) + dc) == pytest.approx(0)


# ----------------------------------------------------------------------------
# 3. SCFR on flat ground with ample friction = support polygon
# ----------------------------------------------------------------------------


def test_scfr_flat_feet_equals_support_polygon():
    feet = flat_feet(mu=1.0)
    t0 = time.perf_counter()
    region = scfr(feet, MASS, tol=1e-4)
    dt = time.perf_counter() - t0
    hull = feet_hull(feet)
    sp = support_polygon([c.corners() for c in feet])
    assert sp.area == pytest.approx(polygon_area(hull), rel=1e-12)
    rel_area = abs(region.area - polygon_area(hull)) / polygon_area(hull)
    d_region_to_hull, d_hull_to_region = polygon_gap(region.vertices, hull)
    print(
        f"\nflat feet SCFR: {len(region.vertices)} vertices, area rel err "
        f"{rel_area:.2e}, max vertex gap {d_region_to_hull:.2e} / "
        f"{d_hull_to_region:.2e} m, {region.n_lp} LPs, {dt * 1e3:.1f} ms"
    )
    assert rel_area < 1e-3
    assert d_region_to_hull < 1e-3 and d_hull_to_region < 1e-3
    assert region.gap < 1e-4 and not region.empty


def test_scfr_external_push_shifts_region():
    """A force F_x at height h shifts the region by -F_x h / (m g) (moment balance).

    Exact when the feet may make any yaw moment (torsion=False); with the torsion
    limits the friction that resists the push also needs a yaw moment, which a
    foot loaded only at its edge cannot make, so the region is a subset.
    """
    free_yaw = [foot_contact(p, yaw, 0.11, 0.06, 1.0, torsion=False) for p, yaw in FEET_POSES]
    push = ExternalWrench(p_W=[0.0, 0.0, 1.0], force=[50.0, 0.0, 0.0])
    shifted = feet_hull(free_yaw) + np.array([-50.0 * 1.0 / (MASS * G), 0.0])
    region = scfr(free_yaw, MASS, external=[push])
    assert max(polygon_gap(region.vertices, shifted)) < 1e-4
    # a pure moment of +50 N m about y (any application point) is the same shift
    # and needs no friction, so the torsion limits do not matter
    moment = ExternalWrench(p_W=[9.0, 9.0, 9.0], force=[0, 0, 0], moment=[0, 50.0, 0])
    for feet in (free_yaw, flat_feet(1.0)):
        assert max(polygon_gap(scfr(feet, MASS, [moment]).vertices, shifted)) < 1e-4
    limited = scfr(flat_feet(1.0), MASS, external=[push])
    assert limited.area < region.area - 1e-4
    assert min(region.signed_distance(v) for v in limited.vertices) > -1e-6


# ----------------------------------------------------------------------------
# 4. Low friction + hand on a wall
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("hand_fz_max", [40.0, 200.0])
def test_scfr_frictionless_hand_on_wall_analytic(hand_fz_max):
    """Feet side by side (x in [-0.11, 0.11]), mu = 0.2, frictionless hand at height h.

    Only the hand can push (-x); the feet resist with friction
    F <= mu/sqrt(2) m g (soles aligned with x), and F <= fz_max. Moment about y:
    m g c_x = F h + sum x_i N_i, so with free yaw moments (torsion=False) the region
    is the feet rectangle stretched forward to 0.11 + F_max h / (m g). With the
    torsion limits that front is reached at c_y = 0 (symmetric friction, no yaw
    moment needed) and the region lies inside the rectangle.
    """
    h = 1.0
    hand = contact_from_normal([0.45, 0.0, h], [-1, 0, 0], mu=0.0, fz_max=hand_fz_max)
    f_max = min(hand_fz_max, 0.2 / math.sqrt(2) * MASS * G)
    x_front = 0.11 + f_max * h / (MASS * G)
    expect = np.array([[-0.11, -0.16], [x_front, -0.16], [x_front, 0.16], [-0.11, 0.16]])
    free = [foot_contact([0, y, 0], 0.0, 0.11, 0.06, 0.2, torsion=False) for y in (0.1, -0.1)]
    region = scfr([*free, hand], MASS)
    assert max(polygon_gap(region.vertices, expect)) < 1e-4
    assert region.area == pytest.approx(0.32 * (x_front + 0.11), rel=1e-3)
    feet = [foot_contact([0, y, 0], 0.0, 0.11, 0.06, 0.2) for y in (0.1, -0.1)]
    limited = scfr([*feet, hand], MASS)
    assert limited.vertices[:, 0].max() == pytest.approx(x_front, abs=1e-6)
    assert limited.signed_distance([x_front - 1e-3, 0.0]) > 0
    assert min(region.signed_distance(v) for v in limited.vertices) > -1e-6
    assert limited.area < region.area - 1e-3


def test_scfr_low_friction_hand_on_wall_changes_region():
    feet_only = scfr(flat_feet(0.2), MASS)
    with_hand = scfr(wall_scenario(), MASS)
    hull = feet_hull(flat_feet(0.2))
    # feet alone: no horizontal force needed, friction does not matter
    assert max(polygon_gap(feet_only.vertices, hull)) < 1e-4
    grow = with_hand.area / feet_only.area - 1.0
    x_gain = with_hand.vertices[:, 0].max() - hull[:, 0].max()
    print(
        f"\nwall hand: area {feet_only.area:.5f} -> {with_hand.area:.5f} m^2 "
        f"({grow:+.1%}), front moves +{x_gain * 1e3:.1f} mm, "
        f"{len(with_hand.vertices)} vertices, {with_hand.n_lp} LPs"
    )
    # the hand can only push back (-x): the region grows toward the wall only
    assert grow > 0.1
    assert x_gain > 0.05
    assert with_hand.vertices[:, 0].min() == pytest.approx(hull[:, 0].min(), abs=1e-4)
    # the feet hull is inside the larger region
    assert min(with_hand.signed_distance(v) for v in hull) > -1e-4


# ----------------------------------------------------------------------------
# 5. SCFR vs the independent corner-force LP on 1,000 CoM positions
# ----------------------------------------------------------------------------


def test_scfr_agrees_with_independent_lp():
    contacts = wall_scenario()
    tol = 1e-4
    region = scfr(contacts, MASS, tol=tol)
    lp = CornerLP(contacts, MASS)
    rng = np.random.default_rng(2024)
    lo = region.vertices.min(axis=0) - 0.1
    hi = region.vertices.max(axis=0) + 0.1
    samples = rng.uniform(lo, hi, size=(1000, 2))
    inside = outside = near = disagree = 0
    t0 = time.perf_counter()
    for cx, cy in samples:
        sd = region.signed_distance([cx, cy])
        if abs(sd) <= tol:
            near += 1
            continue
        ok = lp.feasible([cx, cy, 0.9])
        inside += sd > 0
        outside += sd < 0
        disagree += ok != (sd > 0)
    dt = time.perf_counter() - t0
    print(
        f"\nSCFR vs corner LP: {inside} inside, {outside} outside, {near} within "
        f"{tol} m (excluded), {disagree} disagreements, "
        f"{dt / (inside + outside) * 1e3:.2f} ms/LP"
    )
    assert disagree == 0
    assert inside > 200 and outside > 200


# ----------------------------------------------------------------------------
# 7. Static-equilibrium LP
# ----------------------------------------------------------------------------


def test_static_equilibrium_feet():
    feet = flat_feet(mu=1.0)
    hull = feet_hull(feet)
    hp = halfplanes_from_polygon(hull)
    com_in = np.array([*hull.mean(axis=0), 0.9])
    res = static_equilibrium(feet, MASS, com_in)
    assert res.feasible
    w = res.wrenches
    # balance, recomputed here: forces, and moments about the world origin
    g = np.array([0, 0, -G])
    f_sum = w[:, :3].sum(axis=0) + MASS * g
    n_sum = sum(w[i, 3:] + np.cross(feet[i].p_WC, w[i, :3]) for i in range(len(feet))) + np.cross(
        com_in, MASS * g
    )
    assert np.allclose(f_sum, 0, atol=1e-6) and np.allclose(n_sum, 0, atol=1e-6)
    for c, wi in zip(feet, w, strict=True):
        C, d = wrench_constraints(c)
        assert np.min(C @ wi + d) > -1e-6
    # outside the hull -> infeasible
    far = np.array([hull[:, 0].max() + 0.01, 0.0, 0.9])
    out = static_equilibrium(feet, MASS, far)
    assert not out.feasible and out.wrenches is None
    # agreement with the SCFR (and the support polygon) on sampled CoMs
    region = scfr(feet, MASS)
    rng = np.random.default_rng(5)
    checked = 0
    for cxy in rng.uniform(hull.min(axis=0) - 0.05, hull.max(axis=0) + 0.05, (150, 2)):
        sd = region.signed_distance(cxy)
        if abs(sd) < 1e-4:
            continue
        checked += 1
        feas = static_equilibrium(feet, MASS, [*cxy, 0.8]).feasible
        assert feas == (sd > 0)
        assert feas == (signed_distance(hp, cxy) > 0)
    assert checked > 140


def test_static_equilibrium_matches_corner_lp_with_wall():
    contacts = wall_scenario()
    lp = CornerLP(contacts, MASS)
    rng = np.random.default_rng(9)
    feas = []
    for cxy in rng.uniform([-0.3, -0.35], [0.4, 0.3], (150, 2)):
        com = [*cxy, 0.9]
        a = static_equilibrium(contacts, MASS, com).feasible
        assert a == lp.feasible(com)
        feas.append(a)
    assert 20 < sum(feas) < 130


# ----------------------------------------------------------------------------
# Empty, unbounded, degenerate, bad input
# ----------------------------------------------------------------------------


def test_scfr_infeasible_is_empty():
    weak = [foot_contact([0, 0, 0], 0.0, 0.1, 0.05, 1.0, fz_max=100.0)]
    region = scfr(weak, MASS)  # 100 N cannot carry m g = 490 N
    assert region.empty and region.area == 0.0 and region.vertices.shape == (0, 2)
    assert region.signed_distance([0.0, 0.0]) == -math.inf
    assert not static_equilibrium(weak, MASS, [0, 0, 1]).feasible
    with pytest.raises(InvalidInput):
        signed_distance(region.halfplanes, [0.0, 0.0])


def test_scfr_unbounded_raises_or_clips():
    """Frictionless hands squeezing opposite walls at different heights: unbounded."""
    feet = flat_feet(1.0)
    hands = [
        contact_from_normal([0.5, 0, 1.0], [-1, 0, 0], mu=0.0),
        contact_from_normal([-0.5, 0, 0.5], [1, 0, 0], mu=0.0),
    ]
    with pytest.raises(InvalidInput, match="unbounded"):
        scfr([*feet, *hands], MASS)
    region = scfr([*feet, *hands], MASS, bounds=(-1.0, 2.0, -1.0, 1.0))
    assert region.vertices[:, 0].max() == pytest.approx(2.0)
    # the rear end (hand 2 pushing +x at 0.5 m against foot friction) is a true
    # boundary point for the independent LP
    v = region.vertices[np.argmin(region.vertices[:, 0])]
    lp = CornerLP([*feet, *hands], MASS)
    assert lp.feasible([v[0] + 1e-4, v[1], 0.9])
    assert not lp.feasible([v[0] - 1e-4, v[1], 0.9])


def test_degenerate_inputs():
    with pytest.raises(InvalidInput, match="degenerate"):
        convex_hull_2d([[0, 0], [1, 1], [2, 2], [3, 3]])
    seg = convex_hull_2d([[0, 0], [1, 1], [2, 2]], allow_degenerate=True)
    assert len(seg) == 2
    collinear = [np.array([[x, 0.0, 0.0] for x in (0.0, 0.1, 0.2)])]
    with pytest.raises(InvalidInput, match="degenerate"):
        support_polygon(collinear)
    point_feet = [contact_from_normal([0, y, 0], [0, 0, 1], mu=1.0) for y in (0.1, -0.1)]
    with pytest.raises(InvalidInput, match="degenerate"):
        scfr(point_feet, MASS)


def test_bad_input():
    R = np.eye(3)
    with pytest.raises(InvalidInput, match="empty"):
        support_polygon([])
    with pytest.raises(InvalidInput, match="shape"):
        support_polygon([np.zeros((4, 2))])
    with pytest.raises(InvalidInput, match="finite"):
        support_polygon([np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]])])
    with pytest.raises(InvalidInput, match="finite"):
        convex_hull_2d([[0, 0], [1, 0], [np.inf, 1]])
    with pytest.raises(InvalidInput, match="mu"):
        ContactConstraint(p_WC=[0, 0, 0], R_WC=R, mu=-0.1)
    with pytest.raises(InvalidInput, match="finite"):
        ContactConstraint(p_WC=[0, np.nan, 0], R_WC=R)
    with pytest.raises(InvalidInput, match="shape"):
        ContactConstraint(p_WC=[0, 0], R_WC=R)
    with pytest.raises(InvalidInput, match="rotation"):
        ContactConstraint(p_WC=[0, 0, 0], R_WC=2 * R)
    with pytest.raises(InvalidInput, match="rotation"):
        ContactConstraint(p_WC=[0, 0, 0], R_WC=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(InvalidInput, match="fz_max"):
        ContactConstraint(p_WC=[0, 0, 0], R_WC=R, fz_min=10.0, fz_max=10.0)
    with pytest.raises(InvalidInput, match="half"):
        ContactConstraint(p_WC=[0, 0, 0], R_WC=R, half_x=-0.1)
    feet = flat_feet(1.0)
    with pytest.raises(InvalidInput, match="contacts"):
        scfr([], MASS)
    with pytest.raises(InvalidInput, match="mass"):
        scfr(feet, -1.0)
    with pytest.raises(InvalidInput, match="shape"):
        static_equilibrium(feet, MASS, [0.0, 0.0])
    with pytest.raises(InvalidInput, match="gravity"):
        scfr(feet, MASS, gravity=[0.0, np.nan, -9.81])
    with pytest.raises(InvalidInput, match="ContactConstraint"):
        scfr([feet[0], "foot"], MASS)
