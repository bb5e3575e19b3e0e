"""Compiled emitter sampling towards given mesh triangles (``mesh_light_kernel``, issue 31)
against its NumPy oracle (``TriangleMeshSolidAngle.sample_given`` / ``pdf_given`` with
kernels "numpy"), by area and by spherical triangles, on random and adversarial inputs
(zero-area and sliver triangles, reference points on a triangle's plane and at a vertex,
tiny far triangles below ``min_solid_angle``, u at 0 and 1, w along the plane or away);
renders of the triangle field through both paths; and mutants of the kernel (its source
with one change, run as plain Python, see ``test_kernels.as_python``) that the parity
checks must reject, with the unchanged source as the control.
"""
from __future__ import annotations

import numpy as np
import pytest

import vrlab.distributions.triangle_given as tg
import vrlab.kernels as K
from test_kernels import as_python
from vrlab.distributions import TriangleMeshSurface, mesh_light_kernel, triangle_solid_angle
from vrlab.render import render
from vrlab.render.planning import resolve_kernels

RTOL = 1e-12
METHODS = ("area", "spherical")


def random_case(seed: int = 0, F: int = 60, N: int = 4000) -> tuple:
    """Triangles of sizes 1e-3 to 3 about the origin, reference points around them."""
    g = np.random.default_rng(seed)
    tri = g.normal(size=(F, 1, 3)) * 2 + g.normal(size=(F, 3, 3)) * np.exp(g.uniform(-7, 1, (F, 1, 1)))
    return tri, g.normal(size=(N, 3)) * 3, g.random((N, 2)), g.integers(0, F, N), g.normal(size=(N, 3))


def adversarial_case() -> tuple:
    """Every triangle against every reference point and every special uniform."""
    tri = np.array([
        [[0, 0, 0], [1, 0, 0], [0, 1, 0]],                      # unit right triangle in z = 0
        [[0, 0, 0], [1, 0, 0], [2, 0, 0]],                      # collinear: zero area
        [[0, 0, 0], [0, 0, 0], [0, 1, 0]],                      # a repeated vertex: zero area
        [[0, 0, 0], [1, 0, 0], [0.5, 1e-9, 0]],                 # sliver
        [[0, 0, 0], [1e3, 0, 0], [0, 1e-6, 1e-6]],              # long sliver, tilted
        [[50, 50, 50], [50 + 1e-6, 50, 50], [50, 50 + 1e-6, 50]],   # tiny and far: below min_solid_angle
        [[-1, -1, 2], [1, -1, 2], [0, 1, 2.5]],                 # large, above
    ], float)
    refs = np.array([[0.2, 0.2, 1.0], [0.2, 0.2, 0.0], [3, 3, 0], [0, 0, 0], [0.5, 0, 0], [0.2, 0.2, -1e-13],
                     [0.3, 0.3, 1e-9], [-5, 2, 1], [0, 0, 2.2]], float)
    us = np.array([[0, 0], [0, 1], [1, 0], [1, 1], [0.5, 0.5], [1e-300, 0.3], [np.nextafter(1, 0), 0.7],
                   [0.3, 1e-17]], float)
    F, R, U = len(tri), len(refs), len(us)
    k, r, q = (a.reshape(-1) for a in np.meshgrid(np.arange(F), np.arange(R), np.arange(U), indexing="ij"))
    ws = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [0.3, 0.2, 1], [0, 0, 0], [1, 1, 1e-17]], float)
    return tri, refs[r], us[q], k, ws[np.arange(len(k)) % len(ws)]


CASES = {"random": random_case(0), "random 2": random_case(1, F=5, N=2000), "adversarial": adversarial_case()}


def check_given(tri, ref, u, k, w, method, min_solid_angle=1e-12):
    """sample_given and pdf_given, numba against numpy: the same w, y, dist, pdf (NaN where
    NumPy has NaN) within RTOL; unit w within RTOL absolute."""
    s = TriangleMeshSurface.from_triangles(tri)
    d0, d1 = (s.solid_angle_from(ref, method=method, kernels=kern, min_solid_angle=min_solid_angle)
              for kern in ("numpy", "numba"))
    a, b = d0.sample_given(k, u), d1.sample_given(k, u)
    np.testing.assert_array_equal(b.triangle, a.triangle)
    np.testing.assert_allclose(b.w, a.w, rtol=0, atol=RTOL)
    # spherical: y = ref + t w on k's plane, t = (va . n) / (w . n); a last-place difference
    # of w (sin, atan2) moves t by |dw| / |w . n^| relative (grazing directions): that factor
    cond = 1.0
    if method == "spherical":
        cos = np.abs(np.sum(a.w * s.face_normals[k], -1))
        cond = np.where(s.areas[k] > 0, 1.0 / np.maximum(cos, 1e-300), 1.0)
    np.testing.assert_array_less(np.abs(b.dist - a.dist), RTOL * cond * a.dist + 1e-300)    # NaN fails
    scale = np.maximum(np.abs(a.y), a.dist[:, None]) * np.reshape(cond, (-1, 1))
    np.testing.assert_array_less(np.abs(b.y - a.y), RTOL * scale + 1e-300)
    np.testing.assert_allclose(b.pdf, a.pdf, rtol=RTOL, atol=0)
    np.testing.assert_allclose(d1.pdf_given(w, k), d0.pdf_given(w, k), rtol=RTOL, atol=0)
    np.testing.assert_allclose(d1.pdf_given(a.w, k), d0.pdf_given(a.w, k), rtol=RTOL, atol=0)
    return a


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case", list(CASES))
def test_given_matches_numpy(case, method):
    a = check_given(*CASES[case], method)
    assert np.mean(a.pdf > 0) > 0.5                  # the comparisons are not all of zeros


def test_adversarial_case_reaches_every_branch():
    """The adversarial inputs meet zero densities (the plane, zero area), the area fallback
    below min_solid_angle and the spherical path: the parity above covers them all."""
    tri, ref, u, k, w = CASES["adversarial"]
    s = TriangleMeshSurface.from_triangles(tri)
    d = s.solid_angle_from(ref, method="spherical", kernels="numpy")
    om = triangle_solid_angle(*(t + ref for t in tg.relative(s, k, ref)[:3]), ref)
    assert np.any(om == 0) and np.any((om > 0) & (om < 1e-12)) and np.any(om > 1e-3)
    assert np.any(d.sample_given(k, u).pdf == 0) and np.any(d.pdf_given(w, k) == 0)


def test_given_min_solid_angle_zero_and_large():
    tri, ref, u, k, w = CASES["random"]
    for msa in (0.0, 0.05):
        check_given(tri, ref, u, k, w, "spherical", min_solid_angle=msa)


def test_kernels_switch_and_plan_loads_the_module(raises_naming):
    s = TriangleMeshSurface.from_triangles(CASES["random"][0])
    assert s.solid_angle_from(np.zeros(3), kernels="auto").kernels == "numba"     # numba is in the venv
    assert s.solid_angle_from(np.zeros(3)).kernels == "numpy"
    with raises_naming(ValueError, "kernels"):
        s.solid_angle_from(np.zeros(3), kernels="fast")
    assert resolve_kernels("numba", "bvh") == "numba"
    assert "vrlab.distributions.mesh_light_kernel" in K._loaded


# -- renders ------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def field(tmp_path_factory):
    from vrlab.render import load_scene
    from vrlab.testing.triangle_field import write_triangle_field

    return load_scene(write_triangle_field(tmp_path_factory.mktemp("field"), width=24, height=16))


@pytest.mark.parametrize("strategy", ["light", "restir"])
@pytest.mark.parametrize("method", METHODS)
def test_render_numba_equals_numpy(field, strategy, method):
    """Same seed, both kernels, light BVH (split mesh lights): the same image, pixel for
    pixel.  By area the kernel does the NumPy operations in order (no transcendental
    function), so the images are equal; spherical samples may differ in the last place
    (sin, atan2), which the float32 image has not shown (0 pixels differ): asked to 1e-6."""
    for s in field.shapes:
        if s.emitter is not None:
            s.emitter.triangle_sampling = method
    kw = dict(rng=7, light_selection="bvh", workers=1)
    ref, got = (render(field, 2, strategy, kernels=kern, **kw) for kern in ("numpy", "numba"))
    assert ref.extra["kernels"] == "numpy" and got.extra["kernels"] == "numba"
    assert np.any(ref.value > 0)
    if method == "area":
        np.testing.assert_array_equal(got.value, ref.value)
    else:
        np.testing.assert_allclose(got.value, ref.value, rtol=1e-6, atol=0)


# -- mutants --------------------------------------------------------------------------------------
MUTANTS = {
    "barycentric map sqrt(u) -> u": ("        su = math.sqrt(u[i, 0])\n", "        su = u[i, 0]\n"),
    "area fallback's map sqrt(u) -> u": ("    su = math.sqrt(u1)\n", "    su = u1\n"),
    "area density without the distance squared": ("return 2.0 * t * t / wn", "return 2.0 / wn"),
    "area density without the cosine": ("return 2.0 * t * t / wn", "return 2.0 * t * t"),
    "w not normalised": ("w = _unit(v, _row(face_normals, kk))", "w = v"),
    "density behind the reference point": ("math.isfinite(t) and t > 0)", "math.isfinite(t))"),
    "Arvo's h = u1 Omega": ("h = 0.5 * u1 * omega", "h = u1 * omega"),
    "no area fallback below min_solid_angle": ("if om >= floor:", "if om > 0.0:"),
    "second arc: 1 - cos theta = u2 |d|^2": ("m = 0.5 * u2 * _dot(d, d)", "m = u2 * _dot(d, d)"),
}


def _checks():
    with np.errstate(all="ignore"):                     # as plain Python, 0 / 0 is NumPy's scalar division
        for method in METHODS:
            for case in ("random 2", "adversarial"):
                check_given(*CASES[case], method)


@pytest.mark.parametrize("mutant", [None, *MUTANTS])
def test_parity_fails_on_a_mutated_kernel(mutant, monkeypatch):
    ns = as_python(mesh_light_kernel, *([MUTANTS[mutant]] if mutant else []))
    monkeypatch.setattr(tg, "load_kernel", lambda module, name: ns[name])
    if mutant is None:                                   # the control: the kernel's own source passes
        _checks()
        return
    with pytest.raises(AssertionError):
        _checks()


def test_render_on_forked_workers_equals_numpy(field):
    """The plan loads the kernel before the workers fork: 2 workers, kernels numba, give the
    1-worker NumPy image."""
    for s in field.shapes:
        if s.emitter is not None:
            s.emitter.triangle_sampling = "area"
    kw = dict(rng=4, light_selection="bvh")
    ref = render(field, 2, "mis-power", kernels="numpy", workers=1, **kw)
    got = render(field, 2, "mis-power", kernels="numba", workers=2, **kw)
    assert got.extra["kernels"] == "numba"
    np.testing.assert_array_equal(got.value, ref.value)
