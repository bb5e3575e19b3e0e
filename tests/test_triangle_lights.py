"""Triangle-mesh lights: area sampling of meshes, Arvo's spherical triangles and directions to a mesh.

Solid-angle densities of triangles jump at every projected edge, where per-cell Gauss
quadrature is poor, so the direction tests integrate the expected counts on a grid refined
``sub`` times per axis (``_chi2``), as tests/test_surfaces.py does.  Closed forms: the octant
(pi / 2), Girard's angle excess, the integral of cos / d^2 over the triangle, E[1/p] = the
measure of the directions that reach the light, and Mitsuba 3's mesh area and emitter pdf.
"""
from __future__ import annotations

import numpy as np
import pytest

from vrlab.distributions import (SolidAngleFromArea, SphericalTriangle, TriangleMeshSolidAngle, TriangleMeshSurface,
                                 triangle_solid_angle)
from conftest import InFrame
from vrlab.testing import (AtlasChart, CapChart, TriangleChart, assert_gof, chi2_discrete, chi2_gof, integrate)
from vrlab.testing.chisquare import cell_integrals, histogram, pooled_chi2

TRI = np.array([[1.0, 0.2, 1.5], [-0.6, 0.8, 1.0], [-0.3, -0.9, 1.1]])
# an irregular octahedron (convex, closed, outward winding): every outside ray crosses it twice
OCTA_V = np.array([[1.2, 0, 0], [-0.8, 0, 0], [0, 1.0, 0], [0, -0.6, 0], [0, 0, 1.5], [0, 0, -0.7]]) + [0.1, 0.2, 0.3]
OCTA_F = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
FAR, NEAR = np.array([3.0, 2.5, 4.0]), np.array([0.9, 0.5, 1.2])   # outside the octahedron, NEAR inside its sphere
FAN_REF = np.array([0.1, -0.2, 0.1])                              # near the fan's large triangle


def octahedron():
    return TriangleMeshSurface(OCTA_V, OCTA_F)


def heightfield(n=3, amp=0.2):
    """An open wavy (n x n vertex) grid over [-1, 1]^2: 2 (n-1)^2 triangles of unequal areas, normals up."""
    xs = np.linspace(-1, 1, n)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    V = np.stack([X.ravel(), Y.ravel(), (amp * np.sin(2 * X + 1) * np.cos(Y)).ravel()], 1)
    a = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)).ravel()
    F = np.concatenate([np.stack([a, a + n, a + n + 1], 1), np.stack([a, a + n + 1, a + 1], 1)])
    return V, F


def fan():
    """A large triangle with three small ones along its edges (one mesh, areas 2 to 0.05)."""
    V = np.array([[-1.0, -1, 0], [1.5, -1, 0], [-1, 1.2, 0], [0.3, -1.4, 0.1], [-1.3, 0.2, 0.1], [0.6, 0.6, 0.2]])
    return TriangleMeshSurface(V, [[0, 1, 2], [0, 3, 1], [2, 4, 0], [1, 5, 2]])




def _aim(points, ref, margin=1.02):
    """Axis from ref to the mean of ``points`` and a cap z_min holding every direction to them."""
    v = points - ref
    axis = v.mean(0) / np.linalg.norm(v.mean(0))
    z = np.min(v @ axis / np.linalg.norm(v, axis=1))
    return axis, max(1.0 - (1.0 - z) * margin, -1.0)


def _chi2(dist, points, ref, *, bins=(8, 8), sub=32, quad=2, n=40_000, rng=0, name="chi2"):
    """Chi-square of ``dist`` (directions from ref) on a cap aimed at ``points``, expected
    counts from a grid refined ``sub`` x ``sub``; samples where the pdf is 0 fail it."""
    axis, z_min = _aim(points, ref)
    d, chart = InFrame(dist, axis), CapChart(z_min, 1)
    x = d.sample(np.random.default_rng(rng).random((n, 2)))
    counts, outside = histogram(chart.to_param(x), bins)
    outside += int(np.sum(~(d.pdf(x) > 0)))
    fine = cell_integrals(d.pdf, chart, (bins[0] * sub, bins[1] * sub), quad)
    expected = n * fine.reshape(bins[0], sub, bins[1], sub).sum(axis=(1, 3))
    res = pooled_chi2(counts, np.maximum(expected, 1e-9 * n / expected.size), 5.0, name)
    if outside:
        res.outside, res.pvalue = res.outside + outside, 0.0
    return res


class _TriChart(TriangleChart):
    def contains(self, x, tol=1e-9):
        d = np.asarray(x, float) - self.v[2]
        n = np.cross(self.e[0], self.e[1])
        s = self.to_param(x)
        return (np.abs(d @ n) <= tol * np.linalg.norm(n)) & np.all((s >= -tol) & (s <= 1 + tol), -1)


def mesh_chart(surface):
    return AtlasChart([_TriChart(*surface.vertices[f]) for f in surface.faces])


# ----------------------------------------------------------------------------- closed forms

def test_solid_angle_closed_forms():
    """Octant: pi/2; Girard: Omega = alpha + beta + gamma - pi; int cos / d^2 dA over the
    triangle (Gauss quadrature on its chart); batched triangles; 0 from a point in the plane."""
    assert triangle_solid_angle([1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0]) == pytest.approx(np.pi / 2, rel=1e-14)
    assert triangle_solid_angle([5, 0, 0], [0, 7, 0], [0, 0, 2], [0, 0, 0]) == pytest.approx(np.pi / 2, rel=1e-14)
    rng = np.random.default_rng(1)
    a, b, c, ref = rng.normal(size=(4, 50, 3))
    A, B, C = (v / np.linalg.norm(v, axis=-1, keepdims=True) for v in (a - ref, b - ref, c - ref))

    def angle(p, q, r):                                # angle at p between the arcs to q and r
        t1, t2 = q - p * np.sum(q * p, -1, keepdims=True), r - p * np.sum(r * p, -1, keepdims=True)
        return np.arccos(np.sum(t1 * t2, -1) / np.linalg.norm(t1, axis=-1) / np.linalg.norm(t2, axis=-1))

    girard = angle(A, B, C) + angle(B, C, A) + angle(C, A, B) - np.pi
    np.testing.assert_allclose(triangle_solid_angle(a, b, c, ref), girard, rtol=1e-9)
    chart, ref0 = TriangleChart(*TRI), np.array([0.2, -0.1, -0.3])
    normal = np.cross(TRI[1] - TRI[0], TRI[2] - TRI[0])
    normal /= np.linalg.norm(normal)

    def cos_over_d2(x):
        v = x - ref0
        d = np.linalg.norm(v, axis=-1)
        return np.abs(v @ normal) / d**3

    assert triangle_solid_angle(*TRI, ref0) == pytest.approx(integrate(cos_over_d2, chart, 64), rel=1e-10)
    assert triangle_solid_angle(*TRI, TRI.mean(0) + 0.3 * (TRI[1] - TRI[0])) == 0.0        # in the plane


def test_spherical_triangle_sample_pdf_invert():
    st = SphericalTriangle(*TRI, [0.0, 0.0, 0.0])
    u = np.random.default_rng(2).random((20_000, 2))
    w = st.sample(u)
    np.testing.assert_allclose(np.linalg.norm(w, axis=-1), 1.0, atol=1e-14)
    np.testing.assert_allclose(st.pdf(w), 1.0 / st.solid_angle, rtol=1e-14)
    np.testing.assert_allclose(st.invert(w), u, atol=1e-11)
    # the corners of the square go to the vertices: u1 = 0 -> A, (1, 1) -> C, u2 = 0 -> B
    unit = TRI / np.linalg.norm(TRI, axis=-1, keepdims=True)
    np.testing.assert_allclose(st.sample(np.array([[0.0, 1.0], [1.0, 1.0], [0.4, 0.0]])), unit[[0, 2, 1]], atol=1e-14)
    assert st.pdf(-w[:10]).max() == 0.0 and st.pdf(np.array([0.0, 0.0, -1.0])) == 0.0


def test_spherical_triangle_batched_matches_one_at_a_time():
    """One triangle per reference point (the renderer's call): as many single calls."""
    rng = np.random.default_rng(3)
    tri = TRI + rng.normal(scale=0.3, size=(40, 3, 3))
    ref = rng.normal(scale=0.2, size=(40, 3))
    u = rng.random((40, 2))
    st = SphericalTriangle(tri[:, 0], tri[:, 1], tri[:, 2], ref)
    w = st.sample(u)
    single = np.array([SphericalTriangle(*tri[i], ref[i]).sample(u[i]) for i in range(40)])
    np.testing.assert_allclose(w, single, atol=1e-14)
    np.testing.assert_allclose(st.pdf(w), [1 / SphericalTriangle(*tri[i], ref[i]).solid_angle for i in range(40)],
                               rtol=1e-13)
    assert SphericalTriangle(TRI[0], TRI[1], TRI[2], ref[:, None, :]).sample(rng.random((40, 7, 2))).shape == (40, 7, 3)


def test_spherical_triangle_chi_square():
    """Far, near (ref close to a large triangle: Omega = 3.5 sr) and a distant small one."""
    results = [_chi2(SphericalTriangle(*TRI, ref), TRI, ref, rng=10 + k, name=f"ref={ref}")
               for k, ref in enumerate([np.zeros(3), np.array([0.1, 0.0, 0.9]), np.array([3.0, 2.0, -5.0])])]
    assert_gof(results, alpha=0.01)


def _split_z(V, ref, n=200_000, rng=4, **kw):
    """z-scores of the fraction of samples in sub-triangles (vertex to a point of the opposite
    edge) against Omega_sub / Omega: a closed-form check of uniformity for any triangle."""
    st = SphericalTriangle(*V, ref, **kw)
    w = st.sample(np.random.default_rng(rng).random((n, 2)))
    z = []
    for i in range(3):
        a, b, c = V[i], V[(i + 1) % 3], V[(i + 2) % 3]
        for f in (0.25, 0.6):
            sub = SphericalTriangle(a, b, b + f * (c - b), ref, **kw)
            p = sub.solid_angle / st.solid_angle
            z.append((np.mean(sub.pdf(w) > 0) - p) / np.sqrt(p * (1 - p) / n))
    return np.array(z)


@pytest.mark.parametrize("V, ref", [
    (TRI * 1e-7 + [0.0, 0.0, 1.0], np.zeros(3)),                                   # 1.3e-14 sr
    (np.array([[1.0, 0, 1e-7], [2, 1, 1e-7], [1.5, -1, 1e-7]]), np.zeros(3)),      # grazing sliver, 2e-8 sr
    (np.array([[1.0, 0, 0], [-0.5, 0.8, 0], [-0.5, -0.8, 0]]), np.array([0, 0, 1e-4])),   # 2 pi - 1e-3 sr
], ids=["tiny", "grazing", "almost-hemisphere"])
def test_spherical_triangle_extreme_shapes(V, ref):
    z = _split_z(V, ref, min_solid_angle=0.0)
    assert np.all(np.abs(z) < 4.5), z                  # 6 binomial z-scores
    st = SphericalTriangle(*V, ref, min_solid_angle=0.0)
    u = np.random.default_rng(5).random((5000, 2))
    w = st.sample(u)
    assert np.all(st.pdf(w) > 0) and np.all(np.isfinite(w))
    np.testing.assert_allclose(st.invert(w), u, atol=1e-6)


def test_small_solid_angles_fall_back_to_area_sampling():
    """Below min_solid_angle: area samples with the area density d^2 / (A |cos|) (that of
    SolidAngleFromArea); from a point in the plane or on the triangle: finite w, density 0."""
    ref = np.array([0.3, -0.2, 0.1])
    fb = SphericalTriangle(*TRI, ref, min_solid_angle=10.0)
    u = np.random.default_rng(6).random((2000, 2))
    area = SolidAngleFromArea(TriangleMeshSurface(TRI, [[0, 1, 2]]), ref)
    np.testing.assert_allclose(fb.sample(u), area.sample(u), atol=1e-14)
    np.testing.assert_allclose(fb.pdf(fb.sample(u)), area.pdf(area.sample(u)), rtol=1e-12)
    np.testing.assert_allclose(fb.invert(fb.sample(u)), u, atol=1e-9)
    for r in (TRI[0] + 1.2 * (TRI[1] - TRI[0]) + 0.5 * (TRI[2] - TRI[0]),        # in the plane, outside
              TRI.mean(0)):                                                     # on the triangle
        st = SphericalTriangle(*TRI, r)
        w = st.sample(u)
        assert st.solid_angle == 0 and np.all(np.isfinite(w)) and np.all(st.pdf(w) == 0)
    degenerate = SphericalTriangle(TRI[0], TRI[1], TRI[1], ref)
    assert np.all(np.isfinite(degenerate.sample(u))) and np.all(degenerate.pdf(degenerate.sample(u)) == 0)


# ----------------------------------------------------------------------------- mesh area sampling

MESHES = {"octahedron": octahedron, "heightfield": lambda: TriangleMeshSurface(*heightfield()), "fan": fan}


@pytest.mark.parametrize("name", sorted(MESHES))
def test_mesh_area_sampling(name):
    """Chi-square on an atlas of the triangles, triangle frequencies = A_k / A, pdf = 1/A
    integrates to 1 and the atlas measures the area."""
    m = MESHES[name]()
    chart = mesh_chart(m)
    bins = (8 * len(m.faces), 8)
    assert_gof(chi2_gof(m, chart, bins, n=60_000, rng=7, name=name))
    x, k = m.sample_point(np.random.default_rng(8).random((60_000, 2)))
    assert_gof(chi2_discrete(k, m.areas / m.area, name=name + " triangles"))
    np.testing.assert_array_equal(m.locate(x), k)
    np.testing.assert_allclose(np.sum((x - m.v0[k]) * m.normal_of(k), -1), 0, atol=1e-14)   # on triangle k
    assert integrate(m.pdf, chart, bins) == pytest.approx(1.0, rel=1e-12)
    assert integrate(lambda x: np.ones(x.shape[:-1]), chart, bins) == pytest.approx(m.area, rel=1e-12)


def test_mesh_hits_and_normals():
    m = octahedron()
    c = np.array([0.1, 0.2, 0.3])                              # where the octahedron's axes cross
    t, k = m.hits(c + [0.01, 0.02, -5.0], [0, 0, 1.0])          # near both apexes: faces 7 and 0
    np.testing.assert_allclose(t, [5 - 0.7 * (1 - 0.01 / 1.2 - 0.02), 5 + 1.5 * (1 - 0.01 / 1.2 - 0.02)], rtol=1e-12)
    assert k.tolist() == [4, 0]
    t, k = m.hits(c, [[0.01, 0.02, 1.0], [1.0, 0.01, 0.02]])   # from inside: one hit each
    assert t.shape == (2, 1) and k[:, 0].tolist() == [0, 0] and np.all((t > 1.1) & (t < 1.5))
    assert np.all(np.isinf(m.intersect(c + [5.0, 5, 5], [1.0, 0, 0])))
    rng = np.random.default_rng(9)
    rays = m.sample(rng.random((500, 2))) - FAR + rng.normal(scale=0.3, size=(500, 3))
    t = m.intersect(FAR, rays)                                 # every ray from outside: 0 or 2 hits
    assert t.shape == (500, 2) and set(np.isfinite(t).sum(1).tolist()) <= {0, 2}
    two = t[np.isfinite(t[:, 1])]
    assert len(two) > 50 and np.all(two[:, 1] > two[:, 0])
    n = m.normal_of(np.arange(8))                              # outward winding normals
    centroids = OCTA_V[OCTA_F].mean(1)
    assert np.all(np.sum(n * (centroids - c), -1) > 0)
    np.testing.assert_allclose(m.normal(centroids), n, atol=1e-15)
    center, radius = m.bounding_sphere()
    assert m.max_hits == 8 and radius == pytest.approx(np.max(np.linalg.norm(OCTA_V - center, axis=1)))


# ----------------------------------------------------------------------------- directions to a mesh

CASES = [("area", "area"), ("spherical", "area"), ("spherical", "solid_angle")]


def test_mesh_directions_chi_square():
    results = []
    for j, (mesh, ref, label) in enumerate([(octahedron(), FAR, "octahedron far"),
                                            (octahedron(), NEAR, "octahedron near"),
                                            (fan(), FAN_REF, "fan near")]):
        pts = np.concatenate([mesh.vertices, mesh.sample(np.random.default_rng(j).random((4000, 2)))])
        for i, (method, selection) in enumerate(CASES):
            d = TriangleMeshSolidAngle(mesh, ref, method, selection)
            results.append(_chi2(d, pts, ref, rng=20 + 3 * j + i, name=f"{label} {method}/{selection}"))
    assert_gof(results, alpha=0.01)


@pytest.mark.parametrize("method, selection", CASES)
def test_mesh_direction_pdf_normalisation_and_agreement(method, selection):
    """pdf integrates to 1 on the cap; sample_point's pdf equals pdf(w); E[1/p] is the solid
    angle of the directions that reach the light (sum Omega_k / 2 for a convex mesh: both
    hits of each ray must be counted, a first-hit pdf would give twice that)."""
    m = octahedron()
    d = TriangleMeshSolidAngle(m, FAR, method, selection)
    axis, z_min = _aim(OCTA_V, FAR)
    total = float(cell_integrals(InFrame(d, axis).pdf, CapChart(z_min, 1), (320, 320), 2).sum())
    assert total == pytest.approx(1.0, abs=3e-3)          # the pdf jumps at every projected edge
    s = d.sample_point(np.random.default_rng(11).random((100_000, 2)))
    np.testing.assert_allclose(s.pdf, d.pdf(s.w), rtol=1e-12)
    np.testing.assert_allclose(s.y, FAR + s.w * s.dist[:, None], atol=1e-12)
    np.testing.assert_allclose(np.sum((s.y - m.v0[s.triangle]) * m.normal_of(s.triangle), -1), 0, atol=1e-12)
    support = triangle_solid_angle(*np.moveaxis(OCTA_V[OCTA_F], 1, 0), FAR).sum() / 2
    inv = 1.0 / s.pdf
    assert abs(inv.mean() - support) <= 4 * inv.std() / np.sqrt(len(inv)) + 1e-12 * support
    t, k = m.hits(FAR, s.w)
    np.testing.assert_allclose(d.pdf_from_hits(s.w, t, k), s.pdf, rtol=1e-12)


def test_area_method_matches_solid_angle_from_area():
    """method="area" is SolidAngleFromArea (same u -> same w, same density), faster."""
    m = octahedron()
    u = np.random.default_rng(12).random((3000, 2))
    fast, slow = m.solid_angle_from(NEAR), SolidAngleFromArea(m, NEAR)
    np.testing.assert_allclose(fast.sample(u), slow.sample(u), atol=1e-13)
    np.testing.assert_allclose(fast.pdf(fast.sample(u)), slow.pdf(slow.sample(u)), rtol=1e-12)


def test_near_a_large_triangle_spherical_sampling_has_lower_variance():
    """E[1/p] over the fan from just above its big triangle = sum of Omega_k (no overlaps):
    all three estimators agree; spherical sampling (by area) has a fraction of the spread of
    area sampling, and selection by solid angle has none."""
    m, ref = fan(), FAN_REF
    exact = triangle_solid_angle(*np.moveaxis(m.vertices[m.faces], 1, 0), ref).sum()
    u = np.random.default_rng(13).random((100_000, 2))
    sd = {}
    for method, selection in CASES:
        inv = 1.0 / TriangleMeshSolidAngle(m, ref, method, selection).sample_point(u).pdf
        assert abs(inv.mean() - exact) <= 4 * inv.std() / np.sqrt(len(inv)) + 1e-12 * exact
        sd[method, selection] = inv.std()
    assert sd["spherical", "area"] < 0.25 * sd["area", "area"] and sd["spherical", "solid_angle"] < 1e-12 * exact


def test_batched_reference_points():
    m = fan()
    rng = np.random.default_rng(14)
    ref = rng.normal(scale=0.5, size=(6, 3)) + [0, 0, 1.0]
    u = rng.random((6, 5, 2))
    for method, selection in CASES:
        d = TriangleMeshSolidAngle(m, ref[:, None, :], method, selection)
        s = d.sample_point(u)
        assert s.w.shape == (6, 5, 3) and s.pdf.shape == (6, 5) and s.triangle.shape == (6, 5)
        for i in range(6):
            one = TriangleMeshSolidAngle(m, ref[i], method, selection).sample_point(u[i])
            np.testing.assert_allclose(s.w[i], one.w, atol=1e-14)
            np.testing.assert_allclose(s.pdf[i], one.pdf, rtol=1e-12)


# ----------------------------------------------------------------------------- Mitsuba

def test_mesh_agrees_with_mitsuba(tmp_path):
    """Mitsuba 3 ``obj`` mesh (face normals) with an ``area`` emitter: surface_area, the
    position pdf 1/A, sampled points on our mesh with Mitsuba's normal, and the emitter's
    solid-angle pdf d^2 / (A |cos|) against method="area" (the heightfield is met once)."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    V, F = heightfield(4, 0.3)
    path = tmp_path / "hf.obj"
    path.write_text("".join("v %.17g %.17g %.17g\n" % tuple(v) for v in V) +
                    "".join("f %d %d %d\n" % tuple(f + 1) for f in F))
    shape = mi.load_dict({"type": "obj", "filename": str(path), "face_normals": True, "emitter": {"type": "area"}})
    m = TriangleMeshSurface(V, F)
    assert shape.surface_area() == pytest.approx(m.area, rel=1e-6)
    rng = np.random.default_rng(15)
    ref = np.array([0.2, -0.3, 1.5])
    it = mi.Interaction3f()
    it.p = mi.Point3f(*ref)
    d = TriangleMeshSolidAngle(m, ref, "area")
    rel = []
    for v in rng.random((200, 2)):
        ps = shape.sample_position(0.0, mi.Point2f(*v))
        assert ps.pdf == pytest.approx(1.0 / m.area, rel=1e-6)
        p = np.array(ps.p, float)
        k = m.locate(p)
        assert abs((p - m.v0[k]) @ m.normal_of(k)) < 1e-5
        np.testing.assert_allclose(np.array(ps.n), m.normal_of(k), atol=1e-5)
        ds, _ = shape.emitter().sample_direction(it, mi.Point2f(*v))
        w = np.array(ds.d, float)
        assert np.isfinite(m.intersect(ref, w)).sum() == 1
        rel.append(d.pdf(w) / ds.pdf - 1.0)
    assert np.max(np.abs(rel)) < 1e-5                  # float32 in Mitsuba: 5e-7 seen


# ----------------------------------------------------------------------------- bad input

@pytest.mark.parametrize("build, exc, name", [
    (lambda: TriangleMeshSurface([[0, 0, 0], [1, 0, 0]], [[0, 1, 2]]), ValueError, "faces"),
    (lambda: TriangleMeshSurface([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0.0, 1, 2]]), TypeError, "faces"),
    (lambda: TriangleMeshSurface([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]]), ValueError, "faces"),
    (lambda: TriangleMeshSurface([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]]), ValueError, "vertices"),
    (lambda: TriangleMeshSurface(TRI, [[0, 1, 2]], normals=np.ones((2, 3))), ValueError, "normals"),
    (lambda: TriangleMeshSurface.from_triangles(np.ones((2, 3))), ValueError, "triangles"),
    (lambda: SphericalTriangle(TRI[0], TRI[1], TRI[2], [0, 0]), ValueError, "ref"),
    (lambda: SphericalTriangle(TRI[0], TRI[1], [np.inf, 0, 0], [0, 0, 0]), ValueError, "c"),
    (lambda: SphericalTriangle(np.ones((4, 3)), TRI[1], TRI[2], np.ones((5, 3))), ValueError, "a, b, c, ref"),
    (lambda: SphericalTriangle(*TRI, [0, 0, 0], min_solid_angle=-1), ValueError, "min_solid_angle"),
    (lambda: SphericalTriangle(*TRI, [0, 0, 0]).sample(np.zeros((4, 3))), ValueError, "u"),
    (lambda: TriangleMeshSolidAngle(object(), [0, 0, 0]), TypeError, "surface"),
    (lambda: TriangleMeshSolidAngle(fan(), [0, 0, 0], method="cone"), ValueError, "method"),
    (lambda: TriangleMeshSolidAngle(fan(), [0, 0, 0], selection="power"), ValueError, "selection"),
    (lambda: TriangleMeshSolidAngle(fan(), [[0, 0, 0]] * 3).sample(np.zeros((4, 2))), ValueError, "u"),
    (lambda: triangle_solid_angle("a", TRI[1], TRI[2], [0, 0, 0]), TypeError, "a"),
])
def test_bad_input(build, exc, name, raises_naming):
    with raises_naming(exc, name):
        build()


class _AreaNotConverted:
    """Mutation: directions sampled as the mesh light does, density left per unit area (1 / A)
    instead of converted to solid angle (1 / A times d^2 / |cos| at the light)."""

    dim, dim_u = 3, 2

    def __init__(self, d, mesh):
        self.d, self.area = d, mesh.area

    def sample(self, u):
        return self.d.sample(u)

    def pdf(self, w):
        return np.where(self.d.pdf(w) > 0, 1.0 / self.area, 0.0)


def test_a_density_not_converted_to_solid_angle_fails():
    m = octahedron()
    wrong = _AreaNotConverted(TriangleMeshSolidAngle(m, FAR, "area", "area"), m)
    pts = np.concatenate([m.vertices, m.sample(np.random.default_rng(0).random((4000, 2)))])
    with pytest.raises(AssertionError):
        assert_gof([_chi2(wrong, pts, FAR, rng=3, name="area density")], alpha=0.01)
    axis, z_min = _aim(OCTA_V, FAR)
    total = float(cell_integrals(InFrame(wrong, axis).pdf, CapChart(z_min, 1), (320, 320), 2).sum())
    assert abs(total - 1.0) > 0.1
