"""pbrt-v4's light BVH (vrlab.distributions.LightBVH): the conditional pmf P(light | point).

Oracles: a plain per-point recursion over the tree with its own scalar importance (angles,
``math``), closed forms (two point lights: phi_j / d_j^2 weights; a light facing away: 0),
chi-square of ``sample``'s frequencies against ``pmf``; and mutations that these must catch.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from vrlab.distributions import LightBVH
from vrlab.distributions import light_bvh as LB
from vrlab.testing import chi2_discrete


def random_scene(L, seed, spheres=0.4, spread=5.0):
    """L lights: boxes around random centres; a share ``spheres`` emit all around, the rest are
    one-sided (theta_o = 0) or two-sided area lights facing random directions."""
    rng = np.random.default_rng(seed)
    c = rng.uniform(-spread, spread, (L, 3))
    e = rng.uniform(0, 0.5, (L, 3))
    w = rng.normal(size=(L, 3))
    w /= np.linalg.norm(w, axis=1)[:, None]
    sph = rng.random(L) < spheres
    return dict(lo=c - e, hi=c + e, w=w, cos_theta_o=np.where(sph, -1.0, 1.0), cos_theta_e=np.zeros(L),
                phi=rng.uniform(0.1, 2.0, L), two_sided=~sph & (rng.random(L) < 0.3))


def random_points(N, seed, spread=6.0):
    rng = np.random.default_rng(seed + 1000)
    n = rng.normal(size=(N, 3))
    n[: N // 4] = 0                      # a quarter without a normal
    return rng.uniform(-spread, spread, (N, 3)), n


# -- the oracle: one point at a time, plain Python -------------------------------------------
def oracle_importance(lo, hi, w, cos_o, cos_e, phi, two, p, n):
    """pbrt-v4's LightBounds importance written with angles: theta' = max(theta_w - theta_o
    - theta_b, 0), zero unless cos theta' > cos theta_e; phi cos theta' / d^2 (d clamped at
    half the diagonal), times cos(max(theta_i - theta_b, 0)) with a normal."""
    if phi <= 0:
        return 0.0
    pc = [(a + b) / 2 for a, b in zip(lo, hi)]
    rel = [a - b for a, b in zip(p, pc)]
    dist = math.sqrt(sum(x * x for x in rel))
    r = math.sqrt(sum((b - a) ** 2 for a, b in zip(lo, hi))) / 2
    d2 = max(dist, r) ** 2
    if dist > 0:
        wi = [x / dist for x in rel]
    else:
        wi = list(w)
    cw = sum(a * b for a, b in zip(w, wi))
    if two:
        cw = abs(cw)
    theta_w = math.acos(max(-1.0, min(1.0, cw)))
    theta_b = math.pi if dist < r else math.asin(min(1.0, r / math.sqrt(max(dist * dist, d2))))
    theta_p = max(theta_w - math.acos(cos_o) - theta_b, 0.0)
    if math.cos(theta_p) <= cos_e:
        return 0.0
    imp = phi * math.cos(theta_p) / d2
    nn = math.sqrt(sum(x * x for x in n))
    if nn > 0:
        theta_i = math.acos(min(1.0, abs(sum(a * b for a, b in zip(wi, n))) / nn))
        imp *= math.cos(max(theta_i - theta_b, 0.0))
    return max(imp, 0.0)


def oracle_pmf(bvh, p, n):
    """{light: probability} at one point, by recursion from the root."""
    nodes = bvh.nodes

    def imp(k):
        return oracle_importance(*(np.asarray(f[k]).tolist() for f in nodes), list(p), list(n))

    out = {}

    def walk(k, prob):
        if bvh.light[k] >= 0:
            out[int(bvh.light[k])] = prob
            return
        a, b = bvh.children[k]
        ia, ib = imp(a), imp(b)
        if ia + ib == 0:
            return
        if ia > 0:
            walk(a, prob * ia / (ia + ib))
        if ib > 0:
            walk(b, prob * ib / (ia + ib))

    if bvh.empty:
        return out
    if bvh.light[0] >= 0:
        return {int(bvh.light[0]): 1.0} if imp(0) > 0 else {}
    walk(0, 1.0)
    return out


def pmf_table(bvh, p, n):
    """(N, L): pmf of every light at every point."""
    N, L = len(p), bvh.n_lights
    return bvh.pmf(np.repeat(p, L, 0), np.repeat(n, L, 0), np.tile(np.arange(L), N)).reshape(N, L)


def agrees_with_oracle(bvh, p, n, rtol=1e-12):
    table = pmf_table(bvh, p, n)
    for i in range(len(p)):
        want = np.zeros(bvh.n_lights)
        for j, q in oracle_pmf(bvh, p[i], n[i]).items():
            want[j] = q
        if not np.allclose(table[i], want, rtol=rtol, atol=1e-15):
            return False
    return True


def chi2_pvalue(bvh, p, n, draws=100_000, seed=0):
    """Pearson p-value of ``sample``'s choices at one point against ``pmf`` (one extra cell:
    no light, with the missing mass 1 - sum pmf)."""
    P = np.repeat(p[None], draws, 0)
    N = np.repeat(n[None], draws, 0)
    u = np.random.default_rng(seed).random(draws)
    j, _ = bvh.sample(P, N, u)
    probs = pmf_table(bvh, p[None], n[None])[0]
    probs = np.append(probs, max(1.0 - probs.sum(), 0.0))
    return chi2_discrete(np.where(j < 0, bvh.n_lights, j), probs).pvalue


# -- (1) the pmf sums to 1 -----------------------------------------------------------------------
@pytest.mark.parametrize("L", [1, 2, 7, 100, 1000])
def test_pmf_sums_to_one_where_no_light_faces_away(L):
    """Lights emitting all around can always reach a point: the pmf sums to 1 everywhere."""
    bvh = LightBVH(**random_scene(L, seed=L, spheres=1.0))
    p, n = random_points(40, seed=L)
    np.testing.assert_allclose(pmf_table(bvh, p, n).sum(1), 1.0, rtol=1e-12)


@pytest.mark.parametrize("L", [1, 2, 7, 100, 1000])
def test_pmf_sums_to_one_minus_the_dead_ends(L):
    """With one-sided lights a walk may end where both children face away: the pmf sums to the
    oracle's reachable mass, 1 at points where no walk dies, and never above 1."""
    bvh = LightBVH(**random_scene(L, seed=L))
    p, n = random_points(12, seed=L)
    total = pmf_table(bvh, p, n).sum(1)
    reach = np.array([sum(oracle_pmf(bvh, p[i], n[i]).values()) for i in range(len(p))])
    np.testing.assert_allclose(total, reach, rtol=1e-12, atol=1e-15)
    assert np.all(total <= 1 + 1e-12)
    if L <= 7:
        assert np.any(np.abs(total - 1) < 1e-12)


# -- (2) chi-square of sample against pmf ------------------------------------------------------
@pytest.mark.parametrize("L, seed", [(2, 0), (7, 1), (100, 2), (1000, 3)])
def test_sample_frequencies_match_pmf(L, seed):
    bvh = LightBVH(**random_scene(L, seed))
    p, n = random_points(3, seed)
    pvalues = [chi2_pvalue(bvh, p[i], n[i], seed=i) for i in range(3)]
    assert min(pvalues) > 1e-3 / 3, pvalues


# -- (3) the exhaustive per-point oracle ---------------------------------------------------------
@pytest.mark.parametrize("L, seed", [(1, 0), (2, 1), (7, 2), (100, 3), (1000, 4)])
def test_pmf_equals_the_recursive_oracle(L, seed):
    bvh = LightBVH(**random_scene(L, seed))
    p, n = random_points(6 if L == 1000 else 25, seed)
    assert agrees_with_oracle(bvh, p, n)


def test_two_point_lights_are_weighed_by_power_over_squared_distance():
    """Closed form: two point lights (degenerate boxes, all directions), no normal: the root's
    children are the lights and P_0 = (phi_0 / d_0^2) / (phi_0 / d_0^2 + phi_1 / d_1^2)."""
    pos = np.array([[0.0, 0, 0], [3.0, 0, 0]])
    phi = np.array([2.0, 5.0])
    bvh = LightBVH(pos, pos, [[0, 0, 1.0]] * 2, [-1.0, -1.0], [0.0, 0.0], phi)
    p = np.random.default_rng(0).uniform(-4, 4, (50, 3))
    wt = phi / ((p[:, None, :] - pos) ** 2).sum(-1)
    np.testing.assert_allclose(pmf_table(bvh, p, np.zeros_like(p)), wt / wt.sum(1)[:, None], rtol=1e-13)


def test_a_light_facing_away_is_never_chosen():
    """A one-sided square light at z = 0 facing +z: points below it get it with pmf 0 (and
    the single-light tree returns no light there, as pbrt-v4's Sample), points above pmf 1.  (The
    bound is conservative: a point just below the plane but off to the side still gets it.)"""
    bvh = LightBVH([[-1, -1, 0.0]], [[1, 1, 0.0]], [[0, 0, 1.0]], [1.0], [0.0], [1.0])
    p = np.array([[0.3, 0.2, -2.0], [2.0, 0.0, -2.0], [0.0, 0.0, 2.0], [4.0, 4.0, 0.5]])
    np.testing.assert_array_equal(bvh.pmf(p, None, np.zeros(4, int)), [0, 0, 1, 1])
    j, pmf = bvh.sample(p, None, np.full(4, 0.5))
    np.testing.assert_array_equal(j, [-1, -1, 0, 0])
    np.testing.assert_array_equal(pmf, [0, 0, 1, 1])
    two = LightBVH([[-1, -1, 0.0]], [[1, 1, 0.0]], [[0, 0, 1.0]], [1.0], [0.0], [1.0], two_sided=np.array([True]))
    np.testing.assert_array_equal(two.pmf(p, None, np.zeros(4, int)), 1.0)


# -- (4) pmf(j) equals the pmf sample reports ----------------------------------------------------
@pytest.mark.parametrize("L", [2, 7, 1000])
def test_pmf_of_the_sampled_light_equals_samples_pmf(L):
    bvh = LightBVH(**random_scene(L, seed=7 + L))
    p, n = random_points(5000, seed=L)
    j, pmf = bvh.sample(p, n, np.random.default_rng(L).random(5000))
    assert (j >= 0).mean() > 0.5
    np.testing.assert_array_equal(bvh.pmf(p, n, j), np.where(j >= 0, pmf, 0.0))
    assert np.all(pmf[j >= 0] > 0) and np.all(pmf[j < 0] == 0)


# -- the tree: bounds hold their children, power adds up, the split finds clusters -------------
def test_node_bounds_contain_their_children():
    bvh = LightBVH(**random_scene(300, seed=5))
    nd = bvh.nodes
    inner = np.flatnonzero(bvh.children[:, 0] >= 0)
    for side in (0, 1):
        c = bvh.children[inner, side]
        assert np.all(nd.lo[inner] <= nd.lo[c]) and np.all(nd.hi[inner] >= nd.hi[c])
        assert np.all(nd.cos_e[inner] <= nd.cos_e[c]) and np.all(nd.two[inner] >= nd.two[c])
        angle = np.arccos(np.clip((nd.w[inner] * nd.w[c]).sum(1), -1, 1))
        whole = nd.cos_o[inner] <= -1
        assert np.all(whole | (angle + np.arccos(nd.cos_o[c]) <= np.arccos(nd.cos_o[inner]) + 1e-9))
    np.testing.assert_allclose(nd.phi[inner], nd.phi[bvh.children[inner, 0]] + nd.phi[bvh.children[inner, 1]])
    assert sorted(bvh.light[bvh.light >= 0]) == list(range(300)) and nd.phi[0] == pytest.approx(bvh.bounds.phi.sum())


def test_the_split_separates_two_clusters():
    a, b = random_scene(40, seed=1, spread=1.0), random_scene(40, seed=2, spread=1.0)
    for s in (a, b):
        s["w"][:] = [0, 0, 1.0]
    b["lo"] += [20, 0, 0]
    b["hi"] += [20, 0, 0]
    bvh = LightBVH(**{k: np.concatenate([a[k], b[k]]) for k in a})
    first = bvh.trail[:, 0]
    assert len(set(first[:40])) == 1 and len(set(first[40:])) == 1 and first[0] != first[40]


def test_point_lights_on_a_line_get_a_balanced_tree():
    """No split has a positive cost (zero-area boxes): the median fallback halves each node."""
    x = np.random.default_rng(3).permutation(64).astype(float)
    pos = np.column_stack([x, np.zeros(64), np.zeros(64)])
    bvh = LightBVH(pos, pos, [[0, 0, 1.0]] * 64, np.full(64, -1.0), np.zeros(64), np.ones(64))
    assert np.all(bvh.depth == 6)


def test_lights_without_power_are_left_out():
    s = random_scene(10, seed=3, spheres=1.0)
    s["phi"][[2, 5]] = 0
    bvh = LightBVH(**s)
    p, n = random_points(20, seed=3)
    table = pmf_table(bvh, p, n)
    assert np.all(table[:, [2, 5]] == 0) and np.allclose(table.sum(1), 1)
    j, _ = bvh.sample(np.repeat(p, 500, 0), np.repeat(n, 500, 0), np.random.default_rng(0).random(10_000))
    assert not np.isin(j, [2, 5]).any()
    s["phi"][:] = 0
    dark = LightBVH(**s)
    assert dark.empty and np.all(dark.sample(p, n, np.full(20, 0.3))[0] == -1)
    assert np.all(pmf_table(dark, p, n) == 0)


def test_points_inside_a_box_and_at_a_point_light():
    pos = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.0, 2.0, 0]])
    bvh = LightBVH(pos - 0.5 * np.array([0, 0, 1]), pos, [[0, 0, 1.0]] * 3, [-1.0] * 3, [0.0] * 3, [1.0, 2, 3])
    p = np.array([[0.0, 0, -0.25], [1.0, 0, 0], [0.0, 2.0, -0.5]])       # inside, on the box corner
    table = pmf_table(bvh, p, np.array([[0, 0, 1.0]] * 3))
    assert np.all(np.isfinite(table)) and np.allclose(table.sum(1), 1)
    assert agrees_with_oracle(bvh, p, np.array([[0, 0, 1.0]] * 3))


def test_infinite_light_probability_is_pbrts():
    bvh = LightBVH(**random_scene(5, seed=0))
    assert bvh.infinite_probability(0) == 0 and bvh.infinite_probability(2) == pytest.approx(2 / 3)
    dark = LightBVH(**{**random_scene(5, seed=0), "phi": np.zeros(5)})
    assert dark.infinite_probability(3) == 1.0


# -- (5) mutations the tests above must catch ----------------------------------------------------
def test_ignoring_the_distance_term_fails_the_oracle(monkeypatch):
    bvh = LightBVH(**random_scene(50, seed=11))
    p, n = random_points(10, seed=11)
    assert agrees_with_oracle(bvh, p, n)
    real = LB.importance_prepared            # the tree walk's importance (prepared node bounds)

    def no_distance(t, q, *args, **kwargs):   # q: points as columns (3, ...)
        d2 = np.maximum(sum((q[k] - t.pc[k]) ** 2 for k in range(3)), t.r2)
        return real(t, q, *args, **kwargs) * d2

    monkeypatch.setattr(LB, "importance_prepared", no_distance)
    assert not agrees_with_oracle(bvh, p, n)


def test_not_rescaling_u_fails_the_chi_square(monkeypatch):
    bvh = LightBVH(**random_scene(7, seed=1, spheres=1.0))
    p, n = random_points(3, seed=1)
    assert min(chi2_pvalue(bvh, p[i], n[i]) for i in range(3)) > 1e-3
    monkeypatch.setattr(LB, "_rescale", lambda u, p0, right: u)
    assert min(chi2_pvalue(bvh, p[i], n[i]) for i in range(3)) < 1e-6


def test_a_cone_union_that_keeps_the_first_cone_fails_the_containment(monkeypatch):
    from vrlab.distributions import light_bounds

    monkeypatch.setattr(light_bounds, "cone_union", lambda wa, ca, wb, cb: (wa, ca))
    with pytest.raises(AssertionError):
        test_node_bounds_contain_their_children()


# -- (6) bad input names the argument ---------------------------------------------------------
def _good():
    return random_scene(4, seed=0)


@pytest.mark.parametrize("change, exc, name", [
    (dict(lo=np.zeros((4, 2))), ValueError, "lo"),
    (dict(hi=np.zeros((3, 3))), ValueError, "hi"),
    (dict(hi=-np.ones((4, 3)) * 9), ValueError, "hi"),
    (dict(w=np.zeros((4, 3))), ValueError, "w"),
    (dict(cos_theta_o=[2.0, 0, 0, 0]), ValueError, "cos_theta_o"),
    (dict(cos_theta_e=[np.nan, 0, 0, 0]), ValueError, "cos_theta_e"),
    (dict(phi=[1.0, -1.0, 1.0, 1.0]), ValueError, "phi"),
    (dict(phi="abcd"), TypeError, "phi"),
    (dict(two_sided=[1, 0, 0, 0]), TypeError, "two_sided"),
    (dict(lo=np.full((4, 3), -1e200)), ValueError, "lo"),
    (dict(hi=np.full((4, 3), 1e200)), ValueError, "hi"),
])
def test_bad_bounds_name_the_argument(raises_naming, change, exc, name):
    with raises_naming(exc, name):
        LightBVH(**{**_good(), **change})


@pytest.mark.parametrize("call, exc, name", [
    (lambda b: b.sample(np.zeros((3, 2)), None, np.zeros(3)), ValueError, "p"),
    (lambda b: b.sample(np.zeros((3, 3)), np.zeros((2, 3)), np.zeros(3)), ValueError, "n"),
    (lambda b: b.sample(np.zeros((3, 3)), None, np.ones(3)), ValueError, "u"),
    (lambda b: b.sample(np.zeros((3, 3)), None, np.zeros(2)), ValueError, "u"),
    (lambda b: b.pmf(np.zeros((3, 3)), None, np.array([0, 1, 4])), ValueError, "j"),
    (lambda b: b.pmf(np.zeros((3, 3)), None, np.array([0.0, 1, 2])), ValueError, "j"),
    (lambda b: b.pmf(np.full((1, 3), np.inf), None, np.array([0])), ValueError, "p"),
    (lambda b: b.sample(np.full((1, 3), 1e200), None, np.zeros(1)), ValueError, "p"),
    (lambda b: b.infinite_probability(-1), ValueError, "n_infinite"),
])
def test_bad_queries_name_the_argument(raises_naming, call, exc, name):
    with raises_naming(exc, name):
        call(LightBVH(**_good()))
