"""Emissive triangle meshes in the light BVH (``light_selection="bvh"``): every triangle is a
leaf, (light j, triangle t) ~ P(j, t | p, n), then w towards t (vrlab.render.light_tree).

* P(j, t | p, n) sums to 1 over all leaves where some light can reach the point, and the
  frequencies of sampled leaves match it (chi-square);
* the density of a light sample is the one ``LightSet.pdf`` reports for its direction (its
  first triangle: see ``LightSet.sample``), and the per-triangle density p_t(w) is the mesh
  density of a one-triangle mesh;
* renders of the many-triangle-lights scene (vrlab.testing.triangle_field: 1200 triangles,
  boxes and spheres) with bvh selection are unbiased against uniform and power selection,
  and agree with Mitsuba 3.
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import render_pair
from test_render import bonferroni_z
from test_render_light_bvh import _mean_z, _z
from vrlab.distributions import TriangleMeshSurface
from vrlab.render import load_scene
from vrlab.render.direct import DirectLighting
from vrlab.testing import chi2_discrete
from vrlab.testing.triangle_field import write_triangle_field


@pytest.fixture(scope="module")
def field(tmp_path_factory):
    return write_triangle_field(tmp_path_factory.mktemp("field"), width=12, height=9)


@pytest.fixture(scope="module")
def lights(field):
    return DirectLighting(load_scene(field), "bvh").lights


def _points(m, seed):
    """Points on the floor and in the air under and among the triangles, with random normals."""
    g = np.random.default_rng(seed)
    p = np.column_stack([g.uniform(-3, 3, m), np.where(g.random(m) < 0.5, 0.0, g.uniform(0, 2.2, m)),
                         g.uniform(-3, 2, m)])
    n = g.normal(size=(m, 3))
    n[p[:, 1] == 0] = [0.0, 1.0, 0.0]
    return p, n / np.linalg.norm(n, axis=1, keepdims=True)


def _leaves(lights):
    tree = lights.tree
    return tree.entry_light, np.maximum(tree.entry_triangle, 0)


def test_every_triangle_is_a_leaf(lights):
    assert lights.split.all() and len(lights) == 4
    assert lights.tree.tree.n_lights == 1200
    assert np.array_equal(lights.tree.n_triangles, [300] * 4)


def test_pmf_over_all_leaves_sums_to_one(lights):
    """sum over leaves of P(j, t | p, n) = 1 - P(dead end), the probability that the walk meets a
    node whose children both have importance 0 (pbrt-v4's walk: no light there; triangles facing
    away sit in the same nodes as others): estimated by sampling, and small on the floor."""
    p, n = _points(60, 0)
    j, t = _leaves(lights)
    E = len(j)
    rows = np.repeat(np.arange(len(p)), E)
    table = lights.selection_pmf(p[rows], np.tile(j, len(p)), n[rows], np.tile(t, len(p))).reshape(len(p), E)
    total = table.sum(1)
    assert np.all(total <= 1 + 1e-12) and np.all(total > 0)
    floor = p[:, 1] == 0
    assert np.all(total[floor] > 0.95)
    m = 4000
    js, pj, _ = lights._select(np.repeat(p, m, 0), np.repeat(n, m, 0), np.random.default_rng(9).random(len(p) * m))
    none = (js < 0).reshape(len(p), m).mean(1)
    se = np.sqrt(np.maximum(total * (1 - total), 1e-4) / m)
    assert np.max(np.abs(none - (1 - total)) / se) < 5
    # the marginal over a mesh's triangles (t = None) is the sum of its leaves
    marg = np.stack([lights.selection_pmf(p, np.full(len(p), i), n) for i in range(len(lights))], 1)
    np.testing.assert_allclose(marg, np.stack([table[:, j == i].sum(1) for i in range(len(lights))], 1),
                               rtol=1e-10, atol=1e-15)


@pytest.mark.parametrize("at", [0, 1, 2])
def test_sampled_leaves_follow_the_pmf(lights, at):
    p, n = _points(3, 5)
    p, n = p[at:at + 1], n[at:at + 1]
    m = 60_000
    j, pj, t = lights._select(np.repeat(p, m, 0), np.repeat(n, m, 0), np.random.default_rng(at).random(m))
    lj, lt = _leaves(lights)
    pmf = lights.selection_pmf(np.repeat(p, len(lj), 0), lj, np.repeat(n, len(lj), 0), lt)
    ok = j >= 0
    entry = lights.tree.first_entry[j[ok]] + t[ok]
    assert abs((~ok).mean() - (1 - pmf.sum())) < 5 * np.sqrt(max(pmf.sum() * (1 - pmf.sum()), 1e-4) / m)
    assert chi2_discrete(entry, pmf / pmf.sum()).pvalue > 1e-4
    np.testing.assert_allclose(pj[ok], pmf[entry], rtol=1e-12)


@pytest.mark.parametrize("method", ["area", "spherical"])
def test_triangle_density_is_the_one_triangle_mesh_density(method):
    g = np.random.default_rng(2)
    tri = g.normal(size=(5, 3, 3)) + [0.0, 0.0, 3.0]
    mesh = TriangleMeshSurface.from_triangles(tri)
    ref = g.normal(size=(400, 3)) * 0.3
    k = g.integers(0, 5, len(ref))
    s = mesh.solid_angle_from(ref, method=method).sample_given(k, g.random((len(ref), 2)))
    assert np.all(np.abs(np.linalg.norm(s.y - ref, axis=1) - s.dist) < 1e-9)
    for i in range(5):
        rows = k == i
        one = TriangleMeshSurface.from_triangles(tri[i:i + 1]).solid_angle_from(ref[rows], method=method)
        np.testing.assert_allclose(s.pdf[rows], one.pdf(s.w[rows]), rtol=1e-9)
        np.testing.assert_allclose(mesh.solid_angle_from(ref[rows], method=method).pdf_given(s.w[rows], i),
                                   s.pdf[rows], rtol=1e-12)


def test_light_sample_density_is_pdf_of_its_direction(lights):
    p, n = _points(4000, 3)
    u3 = np.random.default_rng(4).random((len(p), 3))
    j, w, pdf, front, y, le = lights.sample(p, u3, n)
    ok = j >= 0
    assert ok.mean() > 0.9 and np.all(pdf[~ok] == 0) and not front[~ok].any()
    assert np.all(np.isfinite(y[ok]))
    # rows whose sampled point is the mesh's first point along w (the others contribute 0)
    first = np.zeros(len(p), bool)
    for i in range(len(lights)):
        r = np.flatnonzero(ok & (j == i))
        tt, dist = lights[i].surface.hits(p[r], w[r])[0][:, 0], np.linalg.norm(y[r] - p[r], axis=1)
        assert np.all(tt <= dist * (1 + 1e-7))               # the ray meets the sampled triangle
        first[r] = np.abs(tt - dist) < 1e-7 * dist
    assert first[ok].mean() > 0.85                  # the others: another triangle of the field in front
    back = lights.pdf(p[first], w[first], j[first], None, n[first])
    np.testing.assert_allclose(back, pdf[first], rtol=1e-6)


# --------------------------------------------------------------------- renders
@pytest.mark.parametrize("other", ["uniform", "power"])
@pytest.mark.parametrize("strategy", ["light", "mis-power"])
def test_field_bvh_is_unbiased(field, strategy, other):
    sc = load_scene(field)
    bvh = render_pair(sc, 256, strategy, rng=1, light_selection="bvh")
    ref = render_pair(sc, 1024, strategy, rng=2, light_selection=other)
    z = _z(bvh, ref)
    assert np.max(np.abs(z)) < bonferroni_z(z.size)
    assert abs(_mean_z(bvh, ref)) < 4


@pytest.mark.parametrize("method", ["spherical"])
def test_field_bvh_spherical_triangles_is_unbiased(tmp_path, field, method):
    """The emitters' ``triangle_sampling="spherical"`` (Arvo's spherical triangles per leaf)."""
    xml = field.read_text().replace('<emitter type="area">', '<emitter type="area">'
                                    f'<string name="triangle_sampling" value="{method}"/>')
    sc = load_scene(xml.replace('value="triangle_field_', f'value="{field.parent}/triangle_field_'))
    bvh = render_pair(sc, 128, "mis-power", rng=5, light_selection="bvh")
    ref = render_pair(load_scene(field), 256, "mis-power", rng=6, light_selection="power")
    z = _z(bvh, ref)
    assert np.max(np.abs(z)) < bonferroni_z(z.size)
    assert abs(_mean_z(bvh, ref)) < 4


def test_field_agrees_with_mitsuba(tmp_path):
    pytest.importorskip("mitsuba")
    from vrlab.testing.mitsuba import assert_agrees_with_mitsuba

    path = write_triangle_field(tmp_path, width=24, height=18)
    out = assert_agrees_with_mitsuba(path, samples=400_000, estimator="mis-power", light_selection="bvh", rng=3)
    print(out)


def test_hidden_triangles_of_the_same_mesh_do_not_count(tmp_path):
    """Two stacked emissive layers of one mesh, facing down: from the floor the upper layer is
    hidden by the lower one.  A light sample on the upper layer must be rejected by the shadow
    test (the mesh itself is in front of y), as BSDF samples see only the lower layer."""
    quad = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], float)
    v = np.concatenate([quad + [0, 1.0, 0], quad * 1.3 + [0, 1.3, 0]])
    f = [[1, 2, 3], [1, 3, 4], [5, 6, 7], [5, 7, 8]]             # winding normals down (-y)
    (tmp_path / "layers.obj").write_text("".join(f"v {a} {b} {c}\n" for a, b, c in v)
                                         + "".join(f"f {a} {b} {c}\n" for a, b, c in f))
    xml = f"""<scene version="3.0.0"><integrator type="direct"/>
      <sensor type="perspective"><float name="fov" value="40"/><transform name="to_world">
        <lookat origin="0, 3, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>
        <rfilter type="box"/></film></sensor>
      <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
      <shape type="obj"><string name="filename" value="{tmp_path / 'layers.obj'}"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape></scene>"""
    sc = load_scene(xml)
    bvh = render_pair(sc, 256, "light", rng=1, light_selection="bvh")
    ref = render_pair(sc, 256, "bsdf", rng=2)
    z = _z(bvh, ref)
    assert np.max(np.abs(z)) < bonferroni_z(z.size)
    assert abs(_mean_z(bvh, ref)) < 4
