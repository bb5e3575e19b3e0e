"""Compiled reservoir streaming and ReSTIR reuse (vrlab/estimators/restir_kernel.py, issue 31)
against their NumPy oracle (Reservoir._stream, ReSTIR._reuse / _mis_weights), and the
renderer's compiled reconnection Jacobian (vrlab/render/reuse_kernel.py; BlockPixels._G).

Parity: the same kept samples and picks, sums within 1e-12 relative, on random and
adversarial inputs (zero weights and targets, M = 0, every neighbour missing, one candidate or
contributor, exact ties of the selection uniform).  Renders with kernels "numba" and "numpy"
agree pixel for pixel (same seed).  The switch: the plan loads the helpers for ris / restir
renders ("auto" with numba importable) and reports them.  Each parity check fails on mutants
of the kernel module (its source with one change, run as plain Python: the same code the
compiler sees) substituted for the compiled functions; the unchanged source run so passes.
"""
from __future__ import annotations

import numpy as np
import pytest

from test_kernels import as_python
import vrlab.estimators.restir as restir_mod
import vrlab.estimators.ris as ris_mod
import vrlab.kernels as K
import vrlab.render.reuse as reuse_mod
from vrlab.estimators import ReSTIR, restir_kernel
from vrlab.estimators.restir import PixelView
from vrlab.estimators.ris import Reservoir
from vrlab.render import plan, render, reuse_kernel
from vrlab.render.planning import resolve_kernels
from vrlab.render.reuse import BlockPixels
from vrlab.testing.battery import BIAS_Z, battery_scenes, reference_mean, seed_battery

RTOL = 1e-12


# -- reservoir streaming -------------------------------------------------------------------
def stream_cases(R: int = 400) -> dict:
    """``(reservoir, x, w, u, t)`` per case; weights (R, m) with zeros, ties and one candidate."""
    rng = np.random.default_rng(7)
    m, k = 9, 3

    def start(shape=(R,)):
        return Reservoir(rng.random(shape + (k,)), rng.random(shape) * 2, rng.integers(0, 5, shape).astype(float),
                         rng.random(shape))

    x, t = rng.random((R, m, k)), rng.random((R, m))
    w = rng.exponential(size=(R, m))
    zeros = np.where(rng.random((R, m)) < 0.5, 0.0, w)
    zeros[:R // 8] = 0.0                                          # rows that accept nothing: the old sample stays
    # exact ties u_j cum_j == w_j after the first: weights 1, 1, 2, 4 from an empty reservoir
    # (cum 1, 2, 4, 8) and every u_j = 1/2
    tw = np.tile([1.0, 1.0, 2.0, 4.0], (R, 1))
    tu = np.full((R, 4), 0.5)
    return {
        "random": (start(), x, w, rng.random((R, m)), t),
        "zero weights": (start(), x, zeros, rng.random((R, m)), t),
        "one candidate": (start(), x[:, :1], w[:, :1], rng.random((R, 1)), t[:, :1]),
        "empty, u = 0": (Reservoir.empty((R,), k), x, zeros, np.zeros((R, m)), t),
        "ties of the uniform": (Reservoir.empty((R,), k), x[:, :4], tw, tu, t[:, :4]),
        "scalar start (RIS)": (Reservoir(x[:, 0], 0.0, 0.0, 0.0), x, w, rng.random((R, m)), t),
        "2-d batch": (start((R // 20, 20)), x.reshape(-1, 20, m, k), w.reshape(-1, 20, m),
                      rng.random((R // 20, 20, m)), t.reshape(-1, 20, m)),
        "broadcast candidate (merge)": (start(), x[:1], w, rng.random((R, m)), t[:1]),
    }


def check_stream(res, x, w, u, t) -> None:
    ref, got = (res.update(x, w, u, t, kernels=kern) for kern in ("numpy", "numba"))
    np.testing.assert_array_equal(got.y, ref.y)               # the same candidate kept (copied as is)
    np.testing.assert_array_equal(got.target, ref.target)
    np.testing.assert_array_equal(got.M, ref.M)
    np.testing.assert_allclose(got.w_sum, ref.w_sum, rtol=RTOL, atol=0)


@pytest.mark.parametrize("name", list(stream_cases()))
def test_stream_matches_numpy(name):
    check_stream(*stream_cases()[name])


def test_stream_ties_keep_the_earlier_candidate():
    """u_j cum_j == w_j exactly: candidate j is not taken (strictly less), so with weights
    1, 1, 2, 4 and u_j = 1/2 only the first is kept."""
    res, x, w, u, t = stream_cases()["ties of the uniform"]
    got = res.update(x, w, u, t, kernels="numba")
    np.testing.assert_array_equal(got.y, x[:, 0])
    np.testing.assert_array_equal(got.w_sum, 8.0)


# -- reuse combination -----------------------------------------------------------------------
class Pixels:
    """B pixels of 1-d light points x in [0, 1): p̂_b(x) = a_b (1 + x), f_b = p̂_b where x > vis_b
    (a_b = 0 at some pixels: zero targets); the shift's Jacobian J = j[src, dst] (0 for some pairs)."""

    def __init__(self, B: int, rng, kernels: str):
        self.shape, self.B, self.kernels = (B,), B, kernels
        self.a = np.where(rng.random(B) < 0.15, 0.0, rng.exponential(size=B))
        self.vis = rng.random(B) * 0.4
        self.j = np.where(rng.random((B, B)) < 0.1, 0.0, 0.2 + rng.random((B, B)) * 2)
        np.fill_diagonal(self.j, 1.0)            # a pixel's own sample: the identity

    def phat(self, x, pix):
        return self.a[pix] * (1 + x[..., 0])

    def f(self, x, pix):
        return np.where(x[..., 0] > self.vis[pix], self.phat(x, pix), 0.0)

    nonzero = staticmethod(PixelView.nonzero)

    def shift(self, x, src, dst):
        return x, self.j[src, dst]


def reuse_inputs(mis: str, case: str, N: int = 40, B: int = 30, k: int = 5, seed: int = 3):
    """``(estimator, views (numpy, numba), args of _reuse after the view)``."""
    rng = np.random.default_rng(seed)
    views = [Pixels(B, np.random.default_rng(seed + 1), kern) for kern in ("numpy", "numba")]
    est = ReSTIR(8, k, 3.0, 1, mis, shift=views[0].shift)
    y = rng.random((N, B, 1))
    W = rng.exponential(size=(N, B)) * (rng.random((N, B)) < 0.8)
    M = rng.integers(1, 9, (N, B)).astype(float)
    q = views[0].a[None, :] * (1 + y[..., 0])
    nbr = rng.integers(0, B, (N, B, k))
    present = rng.random((N, B, k)) < 0.7
    us = rng.random((N, B))
    if case == "missing":                      # every neighbour missing at half the pixels
        present[:, ::2] = False
    elif case == "M = 0":
        M[rng.random((N, B)) < 0.5] = 0.0
    elif case == "zero targets":
        q[rng.random((N, B)) < 0.5] = 0.0
        W[q == 0] = 0.0
    elif case == "us = 0 and 1":
        us[:, ::3], us[:, 1::3] = 0.0, 1.0
    return est, views, (y, W, M, q, nbr, present, us)


def check_reuse(est, views, args) -> None:
    ref = est._reuse(views[0], *args, kernels="numpy")
    got = est._reuse(views[1], *args, kernels="numba")
    for name, a, b in zip(("y", "W", "M", "q", "f"), ref, got):
        np.testing.assert_allclose(b, a, rtol=RTOL, atol=0, err_msg=name)


CASES = ("random", "missing", "M = 0", "zero targets", "us = 0 and 1")


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("mis", ["pairwise", "balance", "1/M"])
def test_reuse_matches_numpy(mis, case):
    check_reuse(*reuse_inputs(mis, case))


@pytest.mark.parametrize("k", [0, 1, 9])
def test_reuse_matches_numpy_contributor_counts(k):
    """One contributor (k = 0), one neighbour, and 10 contributors (NumPy's pairwise sums over
    more than 8 terms)."""
    for mis in ("pairwise", "balance", "1/M"):
        check_reuse(*reuse_inputs(mis, "random", k=k))


def test_reuse_tie_of_the_selection_uniform():
    """Resampling weights 1, 1, 2 (1/M weights 1/3, targets 3, W = 1, 1, 2, J = 1) and
    u sum w = 1 = cum_0 exactly: the
    pick is the first s with cum_s > u sum w, contributor 1 (both paths)."""
    est = ReSTIR(8, 2, 3.0, 1, "1/M")
    view = PixelView(lambda x: np.stack([np.full(x.shape[:-1], v) for v in (3.0, 3.0, 6.0)]), None, (3,))
    view.kernels = "numba"
    y = np.array([[[0.1], [0.2], [0.3]]])
    args = (y, np.array([[1.0, 1.0, 2.0]]), np.ones((1, 3)), np.array([[3.0, 3.0, 6.0]]), np.array([[[1, 2], [2, 0], [0, 1]]]),
            np.ones((1, 3, 2), bool), np.full((1, 3), 0.25))
    for kern in ("numpy", "numba"):
        y_new, W, M, q, f = est._reuse(view, *args, kernels=kern)
        assert y_new[0, 0, 0] == 0.2 and M[0, 0] == 3.0, kern


def test_pairwise_without_neighbours_keeps_the_canonical_weight():
    """Every neighbour missing (C = 0): m_0 = 1, W = W_0 q_0 / q_0: the pixel's own reservoir."""
    est, views, (y, W, M, q, nbr, present, us) = reuse_inputs("pairwise", "random")
    present[:] = False
    out = est._reuse(views[1], y, W, M, q, nbr, present, us, kernels="numba")
    np.testing.assert_array_equal(out[0], y)
    keep = (q > 0) & (views[0].f(y, np.arange(y.shape[1])) > 0)
    np.testing.assert_allclose(out[1][keep], W[keep], rtol=RTOL)


# -- mutants -----------------------------------------------------------------------------------
STREAM_MUTANTS = {
    "a tie replaces the kept sample": ("if u[r, j] * cum < w[r, j]:", "if u[r, j] * cum <= w[r, j]:"),
    "the first accepted candidate kept": ("            if u[r, j] * cum < w[r, j]:\n",
                                          "            if last < 0 and u[r, j] * cum < w[r, j]:\n"),
    "the old sum dropped": ("        cum = w_sum[r]\n", "        cum = 0.0\n"),
}
COMBINE_MUTANTS = {
    "pairwise weight without the Jacobian": ("own = _ratio(q_src[r, s], J[r, s])", "own = q_src[r, s]"),
    "resampling weight without the Jacobian": (" * W_src[r, s]) * J[r, s]", " * W_src[r, s])"),
    "M normalised over every contributor": ("share = _ratio(Ms[r, s], C)", "share = _ratio(Ms[r, s], C + Ms[r, 0])"),
    "canonical counted as one neighbour": ("a = _ratio(Ms[r, 0], C)", "a = 1.0"),
    "1/M without the canonical's M": ("            for s in range(S):\n                tmp[s] = Ms[r, s]\n            msum = _sum(tmp, S)",
                                      "            for s in range(S):\n                tmp[s] = Ms[r, s]\n            msum = _sum(tmp[1:], S - 1)"),
    "no neighbour: canonical weight 0": ("if C > 0.0 else 1.0", "if C > 0.0 else 0.0"),
    "tie of the uniform picks the lower": ("c += tmp[s] <= thr", "c += tmp[s] < thr"),
    "balance without the receiving target": ("m[s] = _ratio(Ms[r, s] * P[r, s, s], _sum(tmp, S))",
                                             "m[s] = _ratio(Ms[r, s] * P[r, s, s], _sum(tmp[1:], S - 1))"),
}


def _patched(monkeypatch, change):
    ns = as_python(restir_kernel, *([change] if change else []))
    monkeypatch.setattr(ris_mod, "load_kernel", lambda module, name: ns[name])
    monkeypatch.setattr(restir_mod, "load_kernel", lambda module, name: ns[name])


def _stream_checks():
    cases = stream_cases(R=60)
    for name in ("random", "zero weights", "ties of the uniform"):
        check_stream(*cases[name])
    test_stream_ties_keep_the_earlier_candidate()


def _combine_checks():
    for mis in ("pairwise", "balance", "1/M"):
        for case in ("random", "missing"):
            check_reuse(*reuse_inputs(mis, case, N=4, B=20))
    test_reuse_tie_of_the_selection_uniform()


@pytest.mark.parametrize("mutant", [None, *STREAM_MUTANTS])
def test_stream_parity_fails_on_a_mutated_kernel(mutant, monkeypatch):
    _patched(monkeypatch, STREAM_MUTANTS.get(mutant))
    if mutant is None:                                   # the control: the kernel's own source passes
        _stream_checks()
        return
    with pytest.raises(AssertionError):
        _stream_checks()


@pytest.mark.parametrize("mutant", [None, *COMBINE_MUTANTS])
def test_reuse_parity_fails_on_a_mutated_kernel(mutant, monkeypatch):
    _patched(monkeypatch, COMBINE_MUTANTS.get(mutant))
    if mutant is None:
        _combine_checks()
        return
    with pytest.raises(AssertionError):
        _combine_checks()


# -- the switch and renders ------------------------------------------------------------------------
def test_plan_loads_the_helpers_for_ris_and_restir(monkeypatch):
    assert resolve_kernels("auto", "uniform", "restir") == "numba"
    assert resolve_kernels("numba", "uniform", "ris") == "numba"
    assert resolve_kernels("auto", "uniform", ReSTIR(4, 2)) == "numba"
    from vrlab.render import builtin_scene_path, load_scene
    small = load_scene(builtin_scene_path("cornell_box"))            # rays tested all pairs: nothing gains
    assert resolve_kernels("auto", "uniform", "mis-power", small) == "numpy"
    assert resolve_kernels("auto", "uniform", "restir", small) == "numba"
    assert resolve_kernels("numpy", "uniform", "restir") == "numpy"
    assert "vrlab.estimators.restir_kernel" in K.load_kernels("vrlab.estimators.restir_kernel")
    monkeypatch.setattr(K, "numba_version", lambda: None)                     # as where numba has no wheel
    assert resolve_kernels("auto", "uniform", "restir") == "numpy"


@pytest.mark.parametrize("strategy, selection", [("restir", "uniform"), ("restir", "bvh"), ("ris", "power")])
def test_render_numba_equals_numpy(strategy, selection):
    """Same seed, both kernels: the same image, pixel for pixel (the compiled helpers do the
    NumPy code's operations in its order; the light BVH walk is compiled too with "bvh")."""
    kw = dict(rng=11, light_selection=selection, workers=1, width=40, height=30)
    ref = render("many_lights", 4, strategy, kernels="numpy", **kw)
    got = render("many_lights", 4, strategy, kernels="numba", **kw)
    assert ref.extra["kernels"] == "numpy" and got.extra["kernels"] == "numba"
    np.testing.assert_array_equal(got.value, ref.value)
    np.testing.assert_array_equal(got.stderr, ref.stderr)


def test_render_on_forked_workers_equals_numpy():
    """The plan loads the compiled helpers before the workers fork: 2 workers, kernels numba,
    give the 1-worker NumPy image."""
    kw = dict(rng=2, light_selection="bvh", width=40, height=30)
    ref = render("many_lights", 2, "restir", kernels="numpy", workers=1, **kw)
    got = render("many_lights", 2, "restir", kernels="numba", workers=2, **kw)
    assert got.extra["kernels"] == "numba"
    np.testing.assert_array_equal(got.value, ref.value)


def test_render_with_balance_and_passes_equals_numpy():
    est = ReSTIR(candidates=4, neighbours=3, radius=2.0, passes=2, mis="balance")
    kw = dict(rng=5, workers=1, width=24, height=16)
    # many_lights: the compiled ray walk and the NumPy path give the same bits there (not in
    # cornell_box, whose rays the NumPy path decides in float32)
    ref, got = (render("many_lights", 2, est, kernels=kern, **kw) for kern in ("numpy", "numba"))
    assert got.extra["kernels"] == "numba"
    np.testing.assert_array_equal(got.value, ref.value)


# -- the reconnection Jacobian (vrlab.render.reuse_kernel) ----------------------------------------
@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    return battery_scenes(tmp_path_factory.mktemp("battery"), width=16, height=12)


def block_views(scene, selection: str = "uniform", N: int = 3, seed: int = 0) -> list:
    """BlockPixels of every pixel of ``scene`` (N units), kernels numpy and numba, same camera
    hits (the NumPy path's: the compiled ray walk decides in float64, the all-pairs test in
    float32, so their hit points differ by a float32 rounding)."""
    views, camera = [], None
    for kern in ("numpy", "numba"):
        integ = plan(scene, 2, "restir", light_selection=selection, kernels=kern).integrand
        w, h = scene.sensor.width, scene.sensor.height
        pixels = np.stack(np.unravel_index(np.arange(w * h), (h, w)), -1)
        u = np.random.default_rng(seed).random((len(pixels), N, integ.dim))
        camera = camera or integ.camera(pixels, u)
        hits, d, _, group = camera
        views.append((BlockPixels(integ, pixels, hits, d, group, N), u[..., integ.camera_dims:]))
    return views


def jacobian_inputs(view, u, seed: int = 1):
    """Light points ``(N, B, k, 6)`` (each pixel's first candidate, some with no light, some at a
    shading point itself) and pixels src, dst ``(N, B, k)``."""
    rng = np.random.default_rng(seed)
    N, B, k = u.shape[1], view.B, 4
    x = view.candidates(np.moveaxis(u[..., :3], 1, 0)[:, :, None, :])[0][:, :, 0]         # (N, B, 5)
    x = np.repeat(x[:, :, None], k, 2)
    src, dst = rng.integers(0, B, (N, B, k)), rng.integers(0, B, (N, B, k))
    x[rng.random((N, B, k)) < 0.1, 3] = -1.0                                         # no light
    at = rng.random((N, B, k)) < 0.1                                                 # y = p_src: G_src = 0
    rows = (src * N + np.arange(N)[:, None, None])[at]
    x[at, :3] = view.p[rows]
    x[..., 5] = -1.0               # points of the test's own, not the block's candidates (no cached normals)
    return x, src, dst


def check_jacobian(views) -> None:
    """The reconnection's Jacobian (``shift``) and the evaluations at the receiving pixels
    (``f``, ``phat``: the compiled directions and facing of ``_points``) of both kernels."""
    (v0, u), (v1, _) = views
    x, src, dst = jacobian_inputs(v0, u)
    J0, J1 = v0.shift(x, src, dst)[1], v1.shift(x, src, dst)[1]
    assert np.any(J0 > 0) and np.any(J0 == 0)
    np.testing.assert_allclose(J1, J0, rtol=RTOL, atol=0)
    for pix in (src, dst):
        f0, f1 = v0.f(x, pix), v1.f(x, pix)
        assert np.any(f0 > 0)
        np.testing.assert_allclose(f1, f0, rtol=1e-6, atol=0)          # float32 values
        np.testing.assert_allclose(v1.phat(x, pix), v0.phat(x, pix), rtol=RTOL, atol=0)


@pytest.mark.parametrize("name", ["delta_lights", "cornell_box", "veach_mis", "envmap"])
def test_jacobian_matches_numpy(scenes, name):
    """Sphere, rectangle, point, spot and environment lights; pixels without a shading point."""
    check_jacobian(block_views(scenes[name]))


def test_jacobian_matches_numpy_on_split_triangles(tmp_path):
    from vrlab.render import load_scene
    from vrlab.testing.triangle_field import write_triangle_field

    scene = load_scene(write_triangle_field(tmp_path, width=16, height=12))
    check_jacobian(block_views(scene, "bvh"))


JACOBIAN_MUTANTS = {
    "cos without its absolute value": ("g = abs(c) / (d2", "g = c / (d2"),
    "distance squared, not cubed": ("(d2 * math.sqrt(d2))", "d2"),
    "src and dst swapped": ("out[r] = gd / gs if gs > 0.0 else 0.0", "out[r] = gs / gd if gd > 0.0 else 0.0"),
    "delta lights reconnected as shapes": ("if is_emitter[j[r]]:", "if False:"),
    "facing the back of the light": ("facing = c > 0.0", "facing = c < 0.0"),
    "lights at infinity at distance 1": ("p0 + far * w0, p1 + far * w1, p2 + far * w2", "p0 + w0, p1 + w1, p2 + w2"),
}


@pytest.mark.parametrize("mutant", [None, *JACOBIAN_MUTANTS])
def test_jacobian_parity_fails_on_a_mutated_kernel(scenes, mutant, monkeypatch):
    ns = as_python(reuse_kernel, *([JACOBIAN_MUTANTS[mutant]] if mutant else []))
    monkeypatch.setattr(reuse_mod, "load_kernel", lambda module, name: ns[name])
    views = {name: block_views(scenes[name], N=1) for name in ("delta_lights", "envmap")}
    if mutant is None:
        for v in views.values():
            check_jacobian(v)
        return
    with pytest.raises(AssertionError):
        for v in views.values():
            check_jacobian(v)


# -- unbiased through the compiled path -------------------------------------------------------------
def test_restir_unbiased_with_compiled_helpers(scenes):
    """The bias battery's check (24 seeds against a high-spp reference) with kernels "numba":
    pairwise ReSTIR keeps its image mean; 1/M weights, biased, are caught."""
    scene = scenes["delta_lights"]
    ref = reference_mean(scene)
    fair = seed_battery(scene, "restir", 16, ref, kernels="numba")
    assert abs(fair["z"]) < BIAS_Z, fair
    naive = seed_battery(scene, ReSTIR(candidates=8, neighbours=5, radius=3.0, mis="1/M"), 16, ref, kernels="numba")
    assert naive["z"] < -BIAS_Z, naive


# -- the lights' normals, once per candidate (BlockPixels._light_normals) ---------------------------
def check_cached_normals(view, u) -> None:
    """Gathered copies of the block's candidates (as reuse reads them): the cached normals are
    the direct ``LightSet.point_normals`` of each row, geometric and shading."""
    N = u.shape[1]
    x = view.candidates(np.moveaxis(u[..., :12], 1, 0).reshape(N, view.B, 4, 3))[0]          # (N, B, 4, 6)
    rng = np.random.default_rng(5)
    for _ in range(3):
        pick = x.reshape(-1, 6)[rng.integers(0, x.size // 6, 2000)]
        j = np.rint(pick[:, 3]).astype(np.int64)
        tri = np.rint(pick[:, 4]).astype(np.int64)
        jj = np.maximum(j, 0)
        np.testing.assert_array_equal(view._light_normals(pick, j, False),
                                      view.lights.point_normals(pick[:, :3], j, tri))
        np.testing.assert_array_equal(view._light_normals(pick, jj, True),
                                      view.lights.point_normals(pick[:, :3], jj, tri, shading=True))


def test_light_normals_cached_per_candidate(scenes, tmp_path):
    from vrlab.render import load_scene
    from vrlab.testing.triangle_field import write_triangle_field

    check_cached_normals(*block_views(scenes["delta_lights"])[0])
    check_cached_normals(*block_views(load_scene(write_triangle_field(tmp_path, width=16, height=12)), "bvh")[0])


def test_cached_normals_fail_when_keyed_by_the_light(tmp_path, monkeypatch):
    """A cache keyed by the light j instead of the candidate (a mutant) gives stale normals."""
    from vrlab.render import load_scene
    from vrlab.testing.triangle_field import write_triangle_field

    real = BlockPixels._light_normals

    def by_light(self, xl, j, shading):
        xl = xl.copy()
        xl[:, 5] = np.maximum(j, 0)
        return real(self, xl, j, shading)

    monkeypatch.setattr(BlockPixels, "_light_normals", by_light)
    with pytest.raises(AssertionError):
        check_cached_normals(*block_views(load_scene(write_triangle_field(tmp_path, width=16, height=12)), "bvh")[0])
