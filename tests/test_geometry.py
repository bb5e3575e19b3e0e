"""SceneGeometry.intersect against a plain per-primitive reference (vrlab.render.accel.geometry, bvh)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from vrlab.render import load_scene
from vrlab.render.accel.bvh import BVH
from vrlab.render.accel.geometry import SceneGeometry


def _scene(shapes: str, tmp_path=None):
    xml = f"""<scene version="3.0.0">
  <integrator type="direct"/>
  <sensor type="perspective"><float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="3"/>
      <rfilter type="box"/></film></sensor>
  {shapes}
</scene>"""
    if tmp_path is None:
        return load_scene(xml)
    (tmp_path / "scene.xml").write_text(xml)              # obj paths are relative to the file
    return load_scene(tmp_path / "scene.xml")


# ----------------------------------------------------------------------------- reference
def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _ref_triangle(o, d, v0, v1, v2, t_min):
    """Moller & Trumbore (1997), one triangle, all rays: t (inf on a miss)."""
    e1, e2 = v1 - v0, v2 - v0
    p = np.cross(d, e2)
    det = p @ e1
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        tv = o - v0
        u = np.sum(tv * p, -1) * inv
        q = np.cross(tv, e1)
        v = np.sum(d * q, -1) * inv
        t = (q @ e2) * inv
        ok = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > t_min)
    return np.where(ok, t, np.inf)


def _ref_quadric(o, d, c, m, t_min):
    """|M^-1 (o + t d - c)| = 1, smallest root > t_min, by the textbook formula."""
    minv = np.linalg.inv(m)
    ol, dl = (o - c) @ minv.T, d @ minv.T
    a, b, cc = np.sum(dl * dl, -1), 2 * np.sum(ol * dl, -1), np.sum(ol * ol, -1) - 1
    disc = b * b - 4 * a * cc
    sq = np.sqrt(np.maximum(disc, 0))
    t1, t2 = (-b - sq) / (2 * a), (-b + sq) / (2 * a)
    t = np.where(t1 > t_min, t1, np.where(t2 > t_min, t2, np.inf))
    return np.where(disc >= 0, t, np.inf), minv


def reference(scene, o, d, t_min=0.0):
    """Closest hit per ray over every primitive of every shape, one primitive at a time."""
    n_rays = len(o)
    best_t, best_k, best_n = np.full(n_rays, np.inf), np.full(n_rays, -1), np.zeros((n_rays, 3))

    def take(t, k, normal):
        b = t < best_t
        best_t[b], best_k[b] = t[b], k
        best_n[b] = normal[b] if normal.ndim == 2 else normal

    for k, s in enumerate(scene.shapes):
        if s.type in ("rectangle", "cube", "obj"):
            for tri in s.triangles():
                n = _unit(np.cross(tri[1] - tri[0], tri[2] - tri[0]))
                if s.type == "rectangle":                       # analytic M^-T z
                    n = s.rectangle()[3]
                take(_ref_triangle(o, d, *tri, t_min), k, n)
        elif s.type in ("sphere", "ellipsoid"):
            c, m = s.ellipsoid()
            t, minv = _ref_quadric(o, d, c, m, t_min)
            x = (o - c + np.where(np.isfinite(t), t, 0)[:, None] * d) @ minv.T
            take(t, k, (-1 if s.flip_normals else 1) * _unit(x @ minv))
        elif s.type == "disk":
            minv = np.linalg.inv(s.to_world[:3, :3])
            ol, dl = (o - s.center) @ minv.T, d @ minv.T
            with np.errstate(divide="ignore", invalid="ignore"):
                t = -ol[:, 2] / dl[:, 2]
                x = ol[:, :2] + t[:, None] * dl[:, :2]
            ok = np.isfinite(t) & (t > t_min) & (np.sum(x * x, -1) <= 1)
            take(np.where(ok, t, np.inf), k, s.disk()[3])
    return best_t, best_k, best_n


SHAPES = """
  <shape type="rectangle"><transform name="to_world"><scale x="3" y="2"/><rotate x="1" angle="-90"/>
    <translate y="-1"/></transform></shape>
  <shape type="rectangle"><boolean name="flip_normals" value="true"/>
    <transform name="to_world"><scale x="-0.5" y="0.7"/><rotate y="1" angle="30"/>
    <translate x="1" z="-1.5"/></transform></shape>
  <shape type="cube"><transform name="to_world"><scale x="0.3" y="0.5" z="0.2"/>
    <rotate x="1" y="1" angle="40"/><translate x="-1" y="0.2" z="0.5"/></transform></shape>
  <shape type="cube"><boolean name="flip_normals" value="true"/>
    <transform name="to_world"><scale x="-0.4" y="0.3" z="0.3"/><translate x="1.2" y="0.5" z="1"/></transform></shape>
  <shape type="sphere"><point name="center" x="0.2" y="0.3" z="-0.4"/><float name="radius" value="0.35"/></shape>
  <shape type="sphere"><boolean name="flip_normals" value="true"/>
    <point name="center" x="-0.5" y="1.2" z="-0.8"/><float name="radius" value="0.25"/></shape>
  <shape type="ellipsoid"><point name="center" x="0.9" y="-0.3" z="-0.2"/>
    <vector name="radii" x="0.2" y="0.5" z="0.3"/><transform name="to_world"><rotate z="1" angle="25"/></transform></shape>
  <shape type="disk"><transform name="to_world"><scale x="0.6" y="0.3"/><rotate x="1" angle="70"/>
    <translate x="-0.2" y="1.5"/></transform></shape>
  <shape type="disk"><boolean name="flip_normals" value="true"/>
    <transform name="to_world"><scale value="0.4"/><translate x="-1.5" y="-0.5" z="-1"/></transform></shape>"""


def _rays(rng, scene, n, geo):
    """Random rays: half aimed at (near) shape centres, a quarter starting just off
    surfaces (1e-4 away, either side: hit decisions are float32), a few grazing ones
    along the floor plane."""
    o = rng.normal(size=(n, 3)) * 1.5
    d = rng.normal(size=(n, 3)) * rng.uniform(0.2, 3.0, (n, 1))          # not unit
    c = np.array([s.center for s in scene.shapes])
    aim = c[rng.integers(len(c), size=n)] + rng.normal(size=(n, 3)) * 0.2 - o
    d[: n // 2] = aim[: n // 2]
    h = geo.intersect(o, d)
    on = np.flatnonzero(h.shape >= 0)[: n // 4]
    side = rng.choice([-1e-4, 1e-4], size=(len(on), 1))
    o[on] = h.p[on] + side * h.n[on]                      # rays starting next to surfaces
    d[-20:] = [1, 0, 0.001]                               # grazing the floor at y = -1
    o[-20:] = np.c_[rng.uniform(-3, -2, 20), np.full(20, -1.0) + rng.uniform(-1e-3, 1e-3, 20),
                    rng.uniform(-1.5, 1.5, 20)]
    return o, d


def _check(scene, o, d, t_min, backend="auto"):
    geo = SceneGeometry(scene, backend=backend)
    h = geo.intersect(o, d, t_min=t_min)
    t, k, n = reference(scene, o, d, t_min)
    hit = np.isfinite(t)
    np.testing.assert_array_equal(h.shape, k)
    np.testing.assert_array_equal(np.isfinite(h.t), hit)
    np.testing.assert_allclose(h.t[hit], t[hit], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(h.n, n, atol=1e-9)
    np.testing.assert_allclose(h.p[hit], o[hit] + t[hit, None] * d[hit], rtol=1e-9, atol=1e-11)
    assert np.all(h.p[~hit] == 0) and np.all(h.n[~hit] == 0) and np.all(np.isinf(h.t[~hit]))
    return h


@pytest.mark.parametrize("t_min", [0.0, 0.3])
def test_matches_reference_all_shape_types(t_min):
    sc = _scene(SHAPES)
    rng = np.random.default_rng(5)
    o, d = _rays(rng, sc, 4000, SceneGeometry(sc))
    h = _check(sc, o, d, t_min)
    assert set(range(len(sc.shapes))) <= set(h.shape.tolist())   # every shape was hit
    assert 0.05 < np.mean(h.shape < 0) < 0.95                      # and misses occur


def test_rays_from_surfaces_leave_them():
    """Rays leaving a surface point (t_min = 0) do not hit it again at t ~ 0; with t_min
    they skip everything closer."""
    sc = _scene(SHAPES)
    geo = SceneGeometry(sc)
    rng = np.random.default_rng(2)
    o, d = _rays(rng, sc, 3000, geo)
    h = geo.intersect(o, d)
    m = h.shape >= 0
    w = rng.normal(size=(m.sum(), 3))
    w *= np.where(np.sum(w * h.n[m], -1) < 0, -1.0, 1.0)[:, None]   # to the normal's side
    p = h.p[m] + 1e-4 * h.n[m]
    _check(sc, p, w, 0.0)
    _check(sc, h.p[m], w, 1e-3)


def test_obj_mesh_bvh_matches_reference(tmp_path):
    """A mesh big enough for the BVH path: a bumpy tessellated sphere (triangles) plus quads."""
    rng = np.random.default_rng(7)
    nu, nv = 12, 8
    th, ph = np.meshgrid(np.linspace(0.1, np.pi - 0.1, nv), np.linspace(0, 2 * np.pi, nu, endpoint=False))
    r = 1 + 0.1 * rng.uniform(size=th.shape)
    v = np.c_[(r * np.sin(th) * np.cos(ph)).ravel(), (r * np.cos(th)).ravel(), (r * np.sin(th) * np.sin(ph)).ravel()]
    faces = [f"f {i * nv + j + 1} {((i + 1) % nu) * nv + j + 1} {((i + 1) % nu) * nv + j + 2} {i * nv + j + 2}"
             for i in range(nu) for j in range(nv - 1)]
    quads = "v 2 0 0\nv 3 0 0\nv 3 1 0\nv 2 1 0\n"
    n_v = len(v)
    text = "\n".join(f"v {a} {b} {c}" for a, b, c in v) + "\n" + quads + "\n".join(faces) \
        + f"\nf {n_v + 1} {n_v + 2} {n_v + 3} {n_v + 4}\n"
    (tmp_path / "mesh.obj").write_text(text)
    sc = _scene('<shape type="obj"><string name="filename" value="mesh.obj"/></shape>'
                '<shape type="obj"><boolean name="flip_normals" value="true"/>'
                '<string name="filename" value="mesh.obj"/><transform name="to_world">'
                '<translate x="-3"/></transform></shape>', tmp_path)
    geo = SceneGeometry(sc, backend="numpy")       # float64 decisions (Embree's: every_kind test)
    assert geo.n_triangles == 2 * (2 * nu * (nv - 1) + 2)
    assert geo.accel is not None                          # 340 triangles: the scene's BVH
    o = rng.normal(size=(3000, 3)) * 3
    d = rng.normal(size=(3000, 3))
    d[::2] = (rng.normal(size=(1500, 3)) * 0.8 + [[-1.5, 0, 0]]) - o[::2]
    h = _check(sc, o, d, 0.0, backend="numpy")
    assert np.mean(h.shape >= 0) > 0.2
    _check(sc, o, d, 0.5, backend="numpy")


def test_builtin_scene_like_rays_and_chunking():
    sc = _scene(SHAPES)
    geo = SceneGeometry(sc)
    rng = np.random.default_rng(3)
    o, d = _rays(rng, sc, 5000, geo)
    a = geo.intersect(o, d)
    b = geo.intersect(o, d, chunk=37)
    np.testing.assert_array_equal(a.shape, b.shape)
    # the disks' (o - c) @ M^-T is a BLAS product whose kernel may depend on the number of
    # rows (a chunk's): t, p, n agree to rounding, not necessarily to the last bit
    for x, y in zip((a.t, a.p, a.n), (b.t, b.p, b.n)):
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-14)
    # broadcasting one origin against many directions
    c = geo.intersect(o[0], d[:10])
    np.testing.assert_array_equal(c.t, geo.intersect(np.repeat(o[:1], 10, 0), d[:10]).t)


@pytest.mark.parametrize("backend", ["numpy", "embree"])
def test_one_bvh_over_every_kind_matches_reference(tmp_path, backend):
    """Above DENSE_COST every primitive (parallelograms, cube faces, mesh triangles, spheres,
    an ellipsoid, disks) goes into one BVH: closest hits equal the one-primitive-at-a-time
    reference, and ``occluded`` equals closest t < t_max (any hit).  With ``"embree"`` the
    planar primitives are Embree's: float32 decisions, so 99.5 % of the rays must agree (the
    rays include grazing ones and ones starting 1e-4 off a surface)."""
    from vrlab.render.accel.embree import embree_available

    if backend == "embree" and not embree_available():
        pytest.skip("embreex is not installed on this platform (the NumPy BVH traces everything)")
    rng = np.random.default_rng(12)
    tri = rng.uniform(-0.2, 0.2, (300, 3, 3)) + rng.uniform(-2, 2, (300, 1, 3)) + [0, 1.5, -3]
    v = tri.reshape(-1, 3)
    text = "\n".join(f"v {a} {b} {c}" for a, b, c in v) + "\n" + \
        "\n".join(f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}" for k in range(300)) + "\n"
    (tmp_path / "soup.obj").write_text(text)
    sc = _scene(SHAPES + '<shape type="obj"><string name="filename" value="soup.obj"/></shape>', tmp_path)
    geo = SceneGeometry(sc, backend=backend)
    assert geo.accel is not None and len(geo.accel) > 300
    assert (geo.accel.embree is not None) == (backend == "embree")
    o, d = _rays(rng, sc, 4000, geo)
    for t_min in (0.0, 0.3):
        if backend == "numpy":                            # float64 decisions: exactly the reference
            h = _check(sc, o, d, t_min, backend=backend)
            continue
        # Embree decides in float32 with its own (CPU-dependent SIMD) code: rays within
        # float32 rounding of an edge or a second surface may go either way
        h = geo.intersect(o, d, t_min=t_min)
        t, k, _ = reference(sc, o, d, t_min)
        same = h.shape == k
        assert same.mean() > 0.995, same.mean()
        both = same & np.isfinite(t)
        np.testing.assert_allclose(h.t[both], t[both], rtol=1e-6)
    assert set(range(len(sc.shapes))) <= set(h.shape.tolist())   # every shape was hit
    t_max = rng.uniform(0, 2, len(o)) * np.where(np.isfinite(h.t), h.t, 5.0)
    agree = geo.occluded(o, d, t_max, t_min=0.3) == (h.t < t_max)
    assert agree.all() if backend == "numpy" else agree.mean() > 0.995
    # float32 rays (the renderer's) take the float64 BVH decisions too
    h32 = geo.intersect(o.astype(np.float32), d.astype(np.float32))
    assert np.mean(h32.shape == geo.intersect(o.astype(np.float32).astype(float),
                                              d.astype(np.float32).astype(float)).shape) == 1.0


def test_bvh_build_is_a_valid_sah_tree():
    """Every primitive in exactly one leaf, node boxes contain their children's and their
    primitives' boxes, and the SAH separates two far clusters at the root."""
    rng = np.random.default_rng(4)
    pts = np.concatenate([rng.normal(size=(500, 3)) * 0.1, rng.normal(size=(300, 3)) * 0.1 + [10, 0, 0]])
    lo, hi = pts - 0.01, pts + 0.01
    bvh = BVH.from_boxes(lo, hi)
    leaves = np.flatnonzero(bvh.count > 0)
    members = np.concatenate([bvh.order[bvh.start[k]:bvh.start[k] + bvh.count[k]] for k in leaves])
    np.testing.assert_array_equal(np.sort(members), np.arange(len(pts)))
    for k in leaves:
        p = bvh.order[bvh.start[k]:bvh.start[k] + bvh.count[k]]
        assert np.all(bvh.lo[k] <= lo[p]) and np.all(bvh.hi[k] >= hi[p])
    inner = np.flatnonzero(bvh.count == 0)
    for c in (bvh.left[inner], bvh.right[inner]):
        assert np.all(bvh.lo[inner] <= bvh.lo[c]) and np.all(bvh.hi[inner] >= bvh.hi[c])
    sides = [bvh.hi[bvh.left[0], 0], bvh.lo[bvh.right[0], 0]]
    assert sides[0] < 1 and sides[1] > 9                       # the root splits the clusters
    assert bvh.count.max() <= 16


def test_bvh_slab_test_finds_all_boxes():
    rng = np.random.default_rng(1)
    tri = rng.uniform(-1, 1, (200, 3, 3)) * 0.3 + rng.uniform(-2, 2, (200, 1, 3))
    bvh = BVH(tri, leaf_size=3)
    o = rng.normal(size=(500, 3)) * 3
    d = rng.uniform(-2, 2, (500, 3)) - o
    seen = np.zeros((500, 200), bool)

    def test(i, j):
        seen[i, j] = True
        return np.full(len(i), np.inf)

    i, _, _ = bvh.closest(o, d, 0.0, np.full(500, np.inf), test)
    assert len(i) == 0
    # every triangle whose box the ray's half-line crosses was tested
    lo, hi = tri.min(1), tri.max(1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = (lo[None] - o[:, None]) / d[:, None]
        t1 = (hi[None] - o[:, None]) / d[:, None]
    near = np.minimum(t0, t1).max(-1)
    far = np.maximum(t0, t1).min(-1)
    crosses = (near <= far) & (far > 0)
    assert crosses.sum() > 300
    assert np.all(seen[crosses])


def test_degenerate_triangles_and_empty_inputs(tmp_path):
    (tmp_path / "d.obj").write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n")
    sc = _scene('<shape type="obj"><string name="filename" value="d.obj"/></shape>', tmp_path)
    geo = SceneGeometry(sc)
    assert geo.n_triangles == 2
    h = geo.intersect([[0.2, 0.2, 1], [1.5, 0.0, 1]], [[0, 0, -1], [0, 0, -1]])
    np.testing.assert_array_equal(h.shape, [0, -1])
    np.testing.assert_allclose(h.t, [1, np.inf])
    np.testing.assert_allclose(h.n[0], [0, 0, 1])
    e = geo.intersect(np.zeros((0, 3)), np.zeros((0, 3)))
    assert e.t.shape == (0,) and e.p.shape == (0, 3) and e.n.shape == (0, 3)


@pytest.mark.parametrize("n_spheres", [5, 24])
def test_sphere_groups_dense_and_culled_match_reference(n_spheres):
    """Spheres only: the float32 all-pairs path (<= DENSE_QUADRICS, world-space sphere
    kernel) and the culled float64 path (more) against the reference; small far spheres
    and rays from inside included."""
    from vrlab.render.accel.groups import DENSE_QUADRICS
    rng = np.random.default_rng(11)
    c = rng.uniform(-3, 3, (n_spheres, 3))
    r = rng.uniform(0.01, 0.5, n_spheres)
    shapes = "".join(f'<shape type="sphere"><point name="center" x="{x}" y="{y}" z="{z}"/>'
                     f'<float name="radius" value="{rr}"/></shape>' for (x, y, z), rr in zip(c, r))
    sc = _scene(shapes)
    geo = SceneGeometry(sc)
    assert geo.quadrics.use_dense == (n_spheres <= DENSE_QUADRICS)
    assert geo.quadrics.radius is not None                     # recognised as spheres
    o = rng.normal(size=(3000, 3)) * 20
    d = c[rng.integers(n_spheres, size=3000)] + rng.normal(size=(3000, 3)) * 0.3 - o
    o[:200] = c[rng.integers(n_spheres, size=200)]             # from sphere centres: exits
    h = _check(sc, o, d, 0.0)
    assert np.mean(h.shape >= 0) > 0.3


def test_culled_ellipsoids_and_grazing_rays_match_reference():
    """More than DENSE_QUADRICS quadrics, rotated and stretched ellipsoids among spheres, go
    through the culling product (one matrix product of 11 ray and 11 bounding-sphere features,
    the discriminant expanded): its rounding must not drop a pair.  Rays aimed at points just
    inside and just outside the spheres' silhouettes (1e-7 of the radius) from far away test
    the slack; the exact test decides them."""
    rng = np.random.default_rng(12)
    n = 30
    c = rng.uniform(-40, 40, (n, 3))
    r = rng.uniform(0.05, 2.0, n)
    shapes = []
    for k in range(n):
        if k % 3:
            shapes.append(f'<shape type="sphere"><point name="center" x="{c[k, 0]}" y="{c[k, 1]}" z="{c[k, 2]}"/>'
                          f'<float name="radius" value="{r[k]}"/></shape>')
        else:
            shapes.append(f'<shape type="ellipsoid"><point name="center" x="{c[k, 0]}" y="{c[k, 1]}" '
                          f'z="{c[k, 2]}"/><vector name="radii" x="{r[k]}" y="{0.3 * r[k]}" z="{1.5 * r[k]}"/>'
                          f'<transform name="to_world"><rotate x="1" y="2" z="0.5" angle="{17 * k}"/></transform>'
                          '</shape>')
    sc = _scene("".join(shapes))
    geo = SceneGeometry(sc)
    assert not geo.quadrics.use_dense
    o = rng.normal(size=(4000, 3)) * 300
    k = rng.integers(n, size=4000)
    aim = rng.normal(size=(4000, 3))
    side = np.cross(aim, c[k] - o)
    side /= np.linalg.norm(side, axis=-1, keepdims=True)
    rim = r[k] * (1 + rng.choice([-1e-7, 1e-7, 0.5, -0.5], size=4000))     # grazing, inside, outside
    d = c[k] + side * rim[:, None] - o
    h = _check(sc, o, d, 0.0)
    assert 0.2 < np.mean(h.shape >= 0) < 0.8


def test_near_ties_pick_the_lowest_primitive():
    """Two coincident rectangles: the float32 pass packs the primitive index into the low
    bits of t, so the earlier shape wins; the float64 t is exact."""
    rect = '<shape type="rectangle"><transform name="to_world"><translate z="{z}"/></transform></shape>'
    sc = _scene(rect.format(z=2.0) + rect.format(z=2.0) + rect.format(z=1.0 + 1e-3))
    geo = SceneGeometry(sc)
    h = geo.intersect(np.array([[0.1, 0.2, 5.0], [0.3, -0.4, 1.5]]), np.array([[0, 0, -1.0], [0, 0, 1.0]]))
    np.testing.assert_array_equal(h.shape, [0, 0])
    np.testing.assert_allclose(h.t, [3.0, 0.5], rtol=1e-14)
    with pytest.raises(ValueError, match="t_min"):
        geo.intersect(np.zeros((1, 3)), np.ones((1, 3)), t_min=-1.0)


def test_cross_and_rows_by_key():
    """``cross`` is the cross product (antisymmetric, orthogonal to both, |a x b| = |a||b| sin);
    ``rows_by_key`` finds the rows of each present key, in order, as a comparison would."""
    from vrlab._vec import cross, rows_by_key
    rng = np.random.default_rng(11)
    a, b = rng.normal(size=(200, 3)), rng.normal(size=(200, 3))
    c = cross(a, b)
    np.testing.assert_allclose(c, -cross(b, a), rtol=0, atol=0)
    np.testing.assert_allclose(np.sum(c * a, -1), 0, atol=1e-12)
    np.testing.assert_allclose(np.sum(c * b, -1), 0, atol=1e-12)
    cos = np.sum(a * b, -1) / np.linalg.norm(a, axis=-1) / np.linalg.norm(b, axis=-1)
    np.testing.assert_allclose(np.linalg.norm(c, axis=-1),
                               np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1) * np.sqrt(1 - cos ** 2),
                               rtol=1e-9)
    np.testing.assert_allclose(cross(a[0], b), cross(np.broadcast_to(a[0], b.shape), b), rtol=0, atol=0)
    values = rng.integers(-1, 9, 500)
    keys = [7, 3, 12, -1, 0]
    got = rows_by_key(values, keys)
    want = [(k, np.flatnonzero(values == k)) for k in keys if (values == k).any()]
    assert [k for k, _ in got] == [k for k, _ in want]
    for (_, r), (_, w) in zip(got, want):
        np.testing.assert_array_equal(r, w)
    assert rows_by_key(values[:0], keys) == [] and rows_by_key(values, []) == []


def test_frames_and_vector_helpers():
    from vrlab._vec import dot, norm
    from vrlab.distributions import Frame, to_local, to_world
    rng = np.random.default_rng(4)
    n = _unit(rng.normal(size=(50, 3)))
    w = rng.normal(size=(50, 3))
    np.testing.assert_allclose(dot(w, n), np.sum(w * n, -1), rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(norm(w), np.linalg.norm(w, axis=-1), rtol=1e-15)
    fr = Frame(n)
    loc = fr.to_local(w)
    np.testing.assert_allclose(loc[:, 2], dot(w, n), atol=1e-14)
    np.testing.assert_allclose(fr.to_world(loc), w, atol=1e-13)
    np.testing.assert_allclose(to_world(to_local(w, n), n), w, atol=1e-13)
    np.testing.assert_allclose(np.linalg.norm(loc, axis=-1), np.linalg.norm(w, axis=-1), rtol=1e-13)
    idx = np.array([3, 7, 7, 0])
    np.testing.assert_array_equal(fr.take(idx).to_local(w[idx]), loc[idx])
    np.testing.assert_array_equal(fr.tile(2).to_local(np.concatenate([w, w])), np.concatenate([loc, loc]))
    assert fr.tile(1) is fr


def test_ray_inside_a_plane_does_not_block_hits_behind():
    """A ray lying in a rectangle's plane gives t = 0/0 = NaN for it; that must be a miss
    (not t = 0), so the rectangle behind is found."""
    sc = _scene('<shape type="rectangle"/>'
                '<shape type="rectangle"><transform name="to_world"><rotate y="1" angle="-90"/>'
                '<translate x="3"/></transform></shape>'
                '<shape type="sphere"><point name="center" x="0" y="5" z="0"/><float name="radius" value="1"/></shape>')
    geo = SceneGeometry(sc)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                      # and no floating-point warnings
        h = geo.intersect(np.array([[-5.0, 0.0, 0.0], [0.0, 5.0, 5.0]]), np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]))
    np.testing.assert_array_equal(h.shape, [1, 2])
    np.testing.assert_allclose(h.t, [8.0, 4.0])


@pytest.mark.parametrize("ellipsoid", [True, False])
def test_float32_rays_give_float32_hits_close_to_the_reference(ellipsoid):
    """float32 rays (the renderer's): the float32 pass's t and primitive, float32 points
    and normals; the same shape as the float64 reference except within rounding of an
    edge, t and n to float32 accuracy.  Quadric groups with an ellipsoid keep their
    float64 finish, sphere-only groups use the float32 one."""
    shapes = SHAPES if ellipsoid else "\n".join(l for l in SHAPES.splitlines() if "ellipsoid" not in l
                                                and "radii" not in l)
    sc = _scene(shapes)
    geo = SceneGeometry(sc)
    assert (geo.quadrics.radius is None) == ellipsoid
    rng = np.random.default_rng(11)
    o, d = _rays(rng, sc, 6000, geo)
    o32, d32 = o.astype(np.float32), d.astype(np.float32)
    h = geo.intersect(o32, d32)
    assert h.p.dtype == h.n.dtype == np.float32
    t, k, n = reference(sc, o32.astype(float), d32.astype(float))
    assert np.mean(h.shape != k) < 2e-3                        # edges and near-ties only
    same = (h.shape == k) & (k >= 0)
    assert same.sum() > 2000
    scale = 1.0 + np.abs(o32[same]).max(-1) / np.linalg.norm(d32[same], axis=-1)
    # the float32 t is ill-conditioned at grazing incidence (error ~ eps32 scale / |cos|:
    # a plane's d.n, a sphere's root of a vanishing discriminant), where an ulp of a
    # float32 BLAS product moves it a lot: the bound grows as 1 / |cos|
    cos = np.abs(np.sum(d32[same] * n[same], -1)) / np.linalg.norm(d32[same], axis=-1)
    assert np.all(np.abs(h.t[same] - t[same]) * cos <= 5e-7 * (t[same] + scale))
    np.testing.assert_allclose(h.n[same], n[same], atol=2e-5)
    np.testing.assert_allclose(h.p[same], o32[same] + h.t[same, None].astype(np.float32) * d32[same], atol=1e-5)
    assert np.all(h.p[h.shape < 0] == 0) and np.all(h.n[h.shape < 0] == 0)


def test_cube_slab_test_axis_parallel_and_inside_rays():
    """Cubes are tested by slabs (dense.closest_boxes): rays parallel to the faces (d_k = 0,
    some exactly in a face's plane), rays from inside (they leave through a face) and the
    face found for the normal agree with the per-triangle reference."""
    sc = _scene('<shape type="cube"><transform name="to_world"><scale x="0.5" y="1" z="2"/>'
                '<translate x="0.25"/></transform></shape>'
                '<shape type="rectangle"><transform name="to_world"><translate z="-3"/></transform></shape>')
    geo = SceneGeometry(sc)
    assert geo.planar[0].kernel.box_faces.shape == (1, 6)
    rng = np.random.default_rng(4)
    n = 3000
    d = np.zeros((n, 3))
    d[np.arange(n), rng.integers(0, 3, n)] = rng.choice([-1.0, 1.0], n)    # along the axes
    o = rng.uniform(-3, 3, (n, 3))
    o[:300, 0] = 0.75                                    # in the plane of the +x face
    o[300:600] = rng.uniform(-0.2, 0.2, (300, 3)) + [0.25, 0, 0]           # inside the cube
    d[600:1000] = rng.normal(size=(400, 3))
    o[600:1000] = rng.uniform(-0.2, 0.2, (400, 3)) + [0.25, 0, 0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for dt in (np.float64, np.float32):
            h = geo.intersect(o.astype(dt), d.astype(dt))
            t, k, nrm = reference(sc, o.astype(dt).astype(float), d.astype(dt).astype(float))
            inplane = np.zeros(n, bool)
            inplane[:300] = d[:300, 0] == 0               # exactly in a face plane: either answer
            ok = ~inplane
            np.testing.assert_array_equal(h.shape[ok], k[ok])
            hit = ok & (k >= 0)
            np.testing.assert_allclose(h.t[hit], t[hit], rtol=1e-6, atol=1e-6)
            np.testing.assert_allclose(h.n[hit], nrm[hit], atol=1e-6)
            assert np.all(h.shape[300:1000] == 0)          # from inside: always the cube


@pytest.mark.parametrize("ellipsoid", [True, False])
def test_distance_queries_match_intersect(ellipsoid):
    """``distance`` (shadow and occlusion queries: t, optionally the shape, no hit data)
    gives intersect's t and shape, for float32 rays (dense pass only, with and without
    the primitive index) and float64 rays, and for a subset of the shapes (``only``)."""
    shapes = SHAPES if ellipsoid else "\n".join(l for l in SHAPES.splitlines() if "ellipsoid" not in l
                                               and "radii" not in l)
    sc = _scene(shapes)
    rng = np.random.default_rng(12)
    for only in (None, [0, 2, 4, 5]):
        geo = SceneGeometry(sc, only)
        o, d = _rays(rng, sc, 3000, SceneGeometry(sc))
        for dt in (np.float32, np.float64):
            h = geo.intersect(o.astype(dt), d.astype(dt))
            t, s = geo.distance(o.astype(dt), d.astype(dt), with_shape=True)
            np.testing.assert_array_equal(s, h.shape)
            np.testing.assert_allclose(t, h.t, rtol=1e-5 if dt is np.float32 else 0,   # float32 t: ~1e-7 |o|
                                       atol=1e-6 if dt is np.float32 else 0)
            # without the primitive index t keeps the low mantissa bits that _pick packs it in
            np.testing.assert_allclose(geo.distance(o.astype(dt), d.astype(dt)), t,
                                       rtol=2e-6 if dt is np.float32 else 0)
        if only is not None:
            assert set(np.unique(h.shape)) <= {-1, *only}


def test_embree_geometry_pickles_and_backend_is_checked(tmp_path):
    """Workers receive the geometry pickled: the Embree scene is rebuilt there, with the same
    hits; an unknown backend is refused naming ``backend``."""
    import pickle

    from vrlab.render.accel.embree import embree_available

    rng = np.random.default_rng(3)
    tri = rng.uniform(-0.2, 0.2, (400, 3, 3)) + rng.uniform(-2, 2, (400, 1, 3))
    text = "\n".join(f"v {a} {b} {c}" for a, b, c in tri.reshape(-1, 3)) + "\n" + \
        "\n".join(f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}" for k in range(400)) + "\n"
    (tmp_path / "soup.obj").write_text(text)
    sc = _scene('<shape type="obj"><string name="filename" value="soup.obj"/></shape>', tmp_path)
    with pytest.raises(ValueError, match="backend"):
        SceneGeometry(sc, backend="optix")
    geo = SceneGeometry(sc, backend="embree" if embree_available() else "numpy")
    o = rng.normal(size=(2000, 3)) * 4
    d = rng.uniform(-2, 2, (2000, 3)) - o
    a = geo.intersect(o, d)
    b = pickle.loads(pickle.dumps(geo)).intersect(o, d)
    np.testing.assert_array_equal(a.shape, b.shape)
    np.testing.assert_array_equal(a.t, b.t)
    assert np.mean(a.shape >= 0) > 0.2


# ----------------------------------------------------------------------------- pooled meshes
def test_greedy_pairs_take_what_the_one_by_one_scan_takes():
    """The vectorised pairing of consecutive triangles takes, in each run of pairable
    positions, the even offsets: exactly the positions of the greedy scan (a pair k joins
    items k and k + 1; a pair overlapping the one taken before is skipped)."""
    from vrlab.render.accel.pool import greedy_pairs

    rng = np.random.default_rng(5)
    for p in (0.0, 0.2, 0.5, 0.9, 1.0):
        ok = rng.random(500) < p
        used, want = np.zeros(len(ok) + 1, bool), []
        for k in range(len(ok)):
            if ok[k] and not used[k]:
                used[k] = used[k + 1] = True
                want.append(k)
        np.testing.assert_array_equal(greedy_pairs(ok), want)


def _obj(path, tri):
    """An OBJ file of separate triangles ``(T, 3, 3)``."""
    path.write_text("\n".join(f"v {a} {b} {c}" for a, b, c in tri.reshape(-1, 3)) + "\n"
                    + "\n".join(f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}" for k in range(len(tri))) + "\n")


def test_meshes_pooled_pair_quads_within_a_mesh_only(tmp_path):
    """Flat-shaded meshes (face_normals) are pooled and their fan-triangulated quads tested as
    parallelograms, but never a triangle of one mesh with one of the next: mesh A holds quad
    Q1 and the first half of Q2, mesh B the second half of Q2 and quad Q3.  Rays through every
    triangle's centroid hit its mesh and report its triangle (the pair's first for a quad)."""
    def quad(x):                  # two triangles (p0, p1, p2), (p0, p2, p3) of the unit square at x, in z = 0
        p0, p1, p2, p3 = (np.array(v, float) + [x, 0, 0] for v in ([0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]))
        return np.array([[p0, p1, p2], [p0, p2, p3]])

    q1, q2, q3 = quad(0.0), quad(2.0), quad(4.0)
    _obj(tmp_path / "a.obj", np.concatenate([q1, q2[:1]]))
    _obj(tmp_path / "b.obj", np.concatenate([q2[1:], q3]))
    shapes = "".join(f'<shape type="obj"><string name="filename" value="{n}.obj"/>'
                     '<boolean name="face_normals" value="true"/></shape>' for n in "ab")
    sc = _scene(shapes, tmp_path)
    for backend in ("numpy", "embree"):
        from vrlab.render.accel.embree import embree_available

        if backend == "embree" and not embree_available():
            continue
        geo = SceneGeometry(sc, backend=backend)
        assert [len(g) for g in geo.planar] == [2, 2]              # Q1, Q3 as parallelograms; Q2's halves
        tri = np.concatenate([q1, q2, q3])
        o = tri.mean(1) + [0, 0, 2]
        h = geo.intersect(o, np.tile([0.0, 0.0, -1.0], (len(o), 1)))
        np.testing.assert_array_equal(h.shape, [0, 0, 0, 1, 1, 1])
        np.testing.assert_array_equal(h.prim, [0, 0, 2, 0, 1, 1])
        np.testing.assert_allclose(h.t, 2.0)
        np.testing.assert_allclose(h.n, np.tile([0.0, 0.0, 1.0], (6, 1)))


def test_embree_pool_drops_zero_area_triangles_and_matches_tables(tmp_path):
    """Above DENSE_COST with Embree the pooled triangles keep no per-triangle tables: their
    hits (normal, t, shape, triangle) equal those of the NumPy BVH over the full tables, and
    zero-area triangles (a repeated vertex) are left out of Embree's mesh."""
    from vrlab.render.accel.embree import embree_available

    if not embree_available():
        pytest.skip("embreex is not installed on this platform")
    rng = np.random.default_rng(8)
    tri = rng.uniform(-0.3, 0.3, (600, 3, 3)) + rng.uniform(-2, 2, (600, 1, 3)) + [0, 0, -4]
    tri[::50, 2] = tri[::50, 1]                                   # 12 zero-area triangles
    _obj(tmp_path / "a.obj", tri[:300])
    _obj(tmp_path / "b.obj", tri[300:])
    shapes = "".join(f'<shape type="obj"><string name="filename" value="{n}.obj"/>'
                     '<boolean name="face_normals" value="true"/></shape>' for n in "ab")
    sc = _scene(shapes, tmp_path)
    emb, ref = SceneGeometry(sc, backend="embree"), SceneGeometry(sc, backend="numpy")
    assert len(emb.accel) == len(ref.accel) == 600 - 12
    o = np.zeros((4000, 3))
    d = tri.mean(1)[rng.integers(600, size=4000)] + rng.normal(size=(4000, 3)) * 0.05
    a, b = emb.intersect(o, d), ref.intersect(o, d)
    same = (a.shape == b.shape) & (a.prim == b.prim)
    assert same.mean() > 0.995 and np.mean(a.shape >= 0) > 0.5        # float32 decisions near edges
    np.testing.assert_allclose(a.t[same & (a.shape >= 0)], b.t[same & (a.shape >= 0)], rtol=1e-9)
    np.testing.assert_array_equal(a.n[same], b.n[same])
    assert not np.isin(a.prim[(a.shape == 0)], np.arange(0, 300, 50)).any()


def test_mesh_with_many_leading_zero_area_triangles_is_accepted(tmp_path):
    """The zero-area check of a mesh looks at its first triangles first, then at all: 100
    degenerate triangles before a real one are accepted (and the real one is hit); a mesh of
    degenerate triangles only is refused, naming faces."""
    from vrlab.render import SceneError

    tri = np.zeros((101, 3, 3))
    tri[:, 1, 0] = 1.0
    tri[:100, 2, 0] = 2.0                                  # collinear: zero area
    tri[100, 2] = [0.0, 1.0, 0.0]
    _obj(tmp_path / "m.obj", tri + [0, 0, -3])
    sc = _scene('<shape type="obj"><string name="filename" value="m.obj"/></shape>', tmp_path)
    h = SceneGeometry(sc).intersect(np.array([[0.2, 0.2, 0.0]]), np.array([[0.0, 0.0, -1.0]]))
    assert h.shape[0] == 0 and h.prim[0] == 100 and h.t[0] == pytest.approx(3.0)
    _obj(tmp_path / "m.obj", tri[:100])
    with pytest.raises(SceneError, match="faces"):
        _scene('<shape type="obj"><string name="filename" value="m.obj"/></shape>', tmp_path)
