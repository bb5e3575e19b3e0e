"""Mitsuba 3's reflectance models in vrlab (issue 22): values, samples and images against
Mitsuba 3 ``scalar_rgb`` through its Python API, and the delta lobes in the estimators:
the smooth ``conductor``, ``plastic``, ``dielectric`` and ``thindielectric``.

Values: ``eval`` (f |cos|), ``pdf`` and ``sample`` (same uniforms -> same direction, weight and
pdf) on random direction pairs, vrlab's ``wo`` = Mitsuba's ``si.wi``
(:mod:`vrlab.testing.mitsuba_bsdf`).  Images: a scene per family rendered by both and judged by
Mitsuba's render-test criterion plus an image-mean z-test
(:func:`vrlab.testing.mitsuba.assert_agrees_with_mitsuba`).
"""
import numpy as np
import pytest

pytest.importorskip("mitsuba")

from test_mitsuba_elements import EMITTERS, H, W, _envmap_file, scene  # noqa: E402
from vrlab.metrics import image_mean  # noqa: E402
from vrlab.render import load_scene, render  # noqa: E402
from vrlab.distributions.base import Distribution  # noqa: E402
from vrlab.render.bsdfs.conductor import Conductor  # noqa: E402
from vrlab.render.bsdfs.dielectric import Dielectric  # noqa: E402
from vrlab.render.bsdfs.fresnel import fresnel_dielectric, refract  # noqa: E402
from vrlab.render.bsdfs.plastic import Plastic  # noqa: E402
from vrlab.render.bsdfs.thindielectric import ThinDielectric  # noqa: E402
from vrlab.render.scene import SceneError  # noqa: E402
from vrlab.render.textures.checkerboard import Checkerboard  # noqa: E402
from vrlab.testing import HemisphereChart, assert_gof, chi2_gof  # noqa: E402
from vrlab.testing.mitsuba import assert_agrees_with_mitsuba, mitsuba_reference, sample_budget  # noqa: E402
from vrlab.testing.mitsuba_bsdf import bsdf_eval_pdf, bsdf_sample, mitsuba_bsdf  # noqa: E402

N = 400


def directions(n: int, seed: int, upper: bool = True) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    if upper:
        v[:, 2] = np.abs(v[:, 2]) + 1e-3
        v /= np.linalg.norm(v, axis=-1, keepdims=True)
    return v


def direction(theta, phi=0.3):
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


def assert_close(a, b, rtol=1e-4, atol=1e-6, what=""):
    a, b = np.asarray(a, float), np.asarray(b, float)
    bad = ~(np.abs(a - b) <= atol + rtol * np.abs(b))
    assert not bad.any(), f"{what}: {int(bad.sum())} of {bad.size} differ, e.g. {a[bad][:3]} vs {b[bad][:3]}"


# ------------------------------------------------------------------ conductor (smooth)
CONDUCTORS = {"none": {}, "Au": {"material": "Au"}, "Cu": {"material": "Cu"},
              "eta-k": {"eta": 1.2, "k": 3.4, "specular_reflectance": 0.8}}


@pytest.mark.parametrize("name", sorted(CONDUCTORS))
def test_conductor_samples_equal_mitsubas(name):
    kw = CONDUCTORS[name]
    ours = Conductor(**kw)
    theirs = mitsuba_bsdf({"type": "conductor", **kw})
    wo, u = directions(N, 1), np.random.default_rng(2).random((N, 2))
    r = bsdf_sample(theirs, wo, u[:, 0], u)
    wi, weight, pdf = ours.sample(wo, u)
    assert_close(wi, r.wi, 0, 1e-6, "wi")
    assert_close(weight, r.weight, 1e-5, 1e-7, "weight")
    assert_close(pdf, r.pdf, 0, 0, "pdf")
    ev, p = bsdf_eval_pdf(theirs, wo, directions(N, 3))         # a delta lobe: 0 off its direction
    assert np.all(ev == 0) and np.all(p == 0)
    assert np.all(ours.eval(wo, directions(N, 3)) == 0) and np.all(ours.pdf(wo, directions(N, 3)) == 0)


def test_conductor_from_the_back_reflects_nothing():
    wi, weight, pdf = Conductor(material="Au").sample(-directions(10, 4), np.full((10, 2), 0.5))
    assert np.all(weight == 0)


def test_conductor_parameters_are_checked(raises_naming):
    with raises_naming(ValueError, "material"):
        Conductor(material="Au", eta=1.0)
    with raises_naming(ValueError, "material"):
        Conductor(material="Unobtainium")
    with raises_naming(ValueError, "eta"):
        Conductor(eta=-1.0)


# ------------------------------------------------------------------ images
MIRROR_BALL = ('<shape type="sphere"><point name="center" value="-0.3, 0.5, 0"/><float name="radius" value="0.5"/>'
               '<bsdf type="conductor"><string name="material" value="Au"/></bsdf></shape>')


@pytest.mark.parametrize("estimator", ["mis-power"])
def test_mirror_ball_agrees_with_mitsuba(tmp_path, estimator):
    env = _envmap_file(tmp_path)
    assert_agrees_with_mitsuba(scene(MIRROR_BALL + f'<emitter type="envmap"><string name="filename" value="{env}"/>'
                                     '</emitter>'), estimator=estimator)


def test_mirror_ball_by_bsdf_sampling_agrees_with_mitsuba():
    """BSDF sampling alone (the mirror's atom has probability 1) under a constant sky: the
    envmap's small sun would give the floor's pixels too heavy a tail for a per-pixel z-test."""
    assert_agrees_with_mitsuba(scene(MIRROR_BALL + EMITTERS["constant"], lights=False), estimator="bsdf")


def test_estimators_that_cannot_reach_a_mirror_are_refused(raises_naming):
    sc = load_scene(scene(MIRROR_BALL))
    for est in ("light", "cosine"):
        with raises_naming(ValueError, "estimator", "conductor"):
            render(sc, 1, est, width=4, height=3)


# ------------------------------------------------------------------ blendbsdf
def _blends():
    from vrlab.render.bsdfs.blendbsdf import BlendBSDF
    from vrlab.render.bsdfs.diffuse import Diffuse
    from vrlab.render.bsdfs.roughconductor import RoughConductor

    red = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.2, 0.5, 0.7]}}
    rough = {"type": "roughconductor", "alpha": 0.3, "distribution": "ggx", "sample_visible": False}
    return {
        "diffuse+rough": (lambda w: BlendBSDF(Diffuse([0.2, 0.5, 0.7]), RoughConductor(alpha=0.3, distribution="ggx",
                                                                                     sample_visible=False), w),
                          lambda w: {"type": "blendbsdf", "weight": w, "a": red, "b": rough}),
        "diffuse+mirror": (lambda w: BlendBSDF(Diffuse([0.2, 0.5, 0.7]), Conductor(material="Au"), w),
                           lambda w: {"type": "blendbsdf", "weight": w, "a": red,
                                      "b": {"type": "conductor", "material": "Au"}}),
    }


@pytest.mark.parametrize("weight", [0.0, 0.3, 1.0])
@pytest.mark.parametrize("name", ["diffuse+rough", "diffuse+mirror"])
def test_blendbsdf_values_equal_mitsubas(name, weight):
    ours_of, theirs_of = _blends()[name]
    ours, theirs = ours_of(weight), mitsuba_bsdf(theirs_of(weight))
    wo, wi = directions(N, 5), directions(N, 6)
    ev, p = bsdf_eval_pdf(theirs, wo, wi)
    assert_close(ours.eval(wo, wi), ev, what="eval")
    assert_close(ours.pdf(wo, wi), p, what="pdf")
    swi, sweight, spdf = ours.sample(wo, np.random.default_rng(7).random((N, 2)))
    cont = spdf > 0
    if name == "diffuse+mirror":          # the mirror's atom: probability weight, value weight R F
        atom = np.isclose(swi[:, 2], wo[:, 2]) & np.isclose(swi[:, 0], -wo[:, 0])
        assert np.allclose(spdf[atom], weight) and np.mean(atom) == pytest.approx(weight, abs=0.08)
        cont &= ~atom
    assert_close(sweight[cont] * spdf[cont, None], ours.eval(wo, swi)[cont], 1e-5, 1e-7, "weight x pdf")
    wrong = ours_of(min(1.0, weight + 0.2))                      # a wrong blend weight is caught
    assert not np.allclose(wrong.eval(wo, wi), ev, rtol=1e-4, atol=1e-6) or weight == 1.0


def test_blendbsdf_lobes_are_techniques():
    ours = _blends()["diffuse+mirror"][0](0.4)
    assert ours.LOBES == ("1.specular", "0.diffuse") and ours.DELTA == ("1.specular",)
    wo = directions(3, 8)
    assert np.allclose(ours.lobe_probabilities(wo), [[0.4, 0.6]] * 3)
    wi, value = ours.delta_value("1.specular", wo)
    assert np.allclose(value, 0.4 * Conductor(material="Au").delta_value("specular", wo)[1])


def blend_scene(weight: float, second: str) -> str:
    return scene('<shape type="sphere"><point name="center" value="-0.3, 0.5, 0"/><float name="radius" value="0.5"/>'
                 f'<bsdf type="blendbsdf"><float name="weight" value="{weight}"/><bsdf type="diffuse"><rgb '
                 f'name="reflectance" value="0.2, 0.5, 0.7"/></bsdf>{second}</bsdf></shape>' + EMITTERS["constant"])


ROUGH = ('<bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha" value="0.3"/>'
         '<boolean name="sample_visible" value="false"/></bsdf>')
MIRROR = '<bsdf type="conductor"><string name="material" value="Cu"/></bsdf>'


@pytest.mark.parametrize("estimator", ["mis-balance"])
def test_blendbsdf_agrees_with_mitsuba(estimator):
    assert_agrees_with_mitsuba(blend_scene(0.35, ROUGH), estimator=estimator)


def test_blendbsdf_with_a_delta_lobe_is_the_blend_of_mitsubas_images():
    """Direct lighting is linear in the BSDF, so the blend's image is (1 - w) I_0 + w I_1 of
    the images with weight 0 and 1.  Mitsuba 3.9.1's own blend of a diffuse and a smooth
    conductor is not: its ``sample`` adds the conductor's delta probability (1) to the diffuse
    density at the mirror direction (pdf 0.545 and weight 0.683 instead of 1 and 0.952 at
    w = 0.35, wo.z = 0.94), which mixes measures and loses 21 % of the sampled albedo
    (``bsdf_sample``: mean weight 0.365 against the linear 0.463).  vrlab keeps the atom's mass
    apart, so it is checked against the blend of Mitsuba's weight-0 and weight-1 images."""
    from vrlab.testing.mitsuba import mitsuba_reference, sample_budget
    from test_mitsuba_elements import H, W

    spp = 4 * max(1, sample_budget() // (W * H))
    w = 0.35
    m0, v0 = mitsuba_reference(blend_scene(0.0, MIRROR), spp)
    m1, v1 = mitsuba_reference(blend_scene(1.0, MIRROR), spp)
    ref = (1 - w) * m0 + w * m1
    # the blend's per-sample variance is unknown in closed form; the larger of the two bounds it well
    assert_agrees_with_mitsuba(blend_scene(w, MIRROR), reference=(ref, np.maximum(v0, v1), spp))
    wo = np.tile(np.array([[0.3, 0.1, 0.9]]) / np.linalg.norm([0.3, 0.1, 0.9]), (40_000, 1))
    ours = _blends()["diffuse+mirror"][0](w)
    _, weight, _ = ours.sample(wo, np.random.default_rng(0).random((40_000, 2)))
    linear = (1 - w) * np.array([0.2, 0.5, 0.7]) + w * Conductor(material="Au").delta_value("specular", wo[:1])[1][0]
    assert np.allclose(weight.mean(0), linear, rtol=0.02)


# ------------------------------------------------------------------ roughconductor's Fresnel term
@pytest.mark.parametrize("kw", [{"material": "Au"}, {"material": "Cr"}, {"eta": 0.2, "k": 2.9},
                                {"material": "none"}])
@pytest.mark.parametrize("dist", ["ggx", "beckmann"])
def test_roughconductor_fresnel_values_equal_mitsubas(kw, dist):
    from vrlab.render.bsdfs.roughconductor import RoughConductor

    ours = RoughConductor(alpha=0.25, distribution=dist, sample_visible=False, **kw)
    theirs = mitsuba_bsdf({"type": "roughconductor", "alpha": 0.25, "distribution": dist, "sample_visible": False,
                           **kw})
    wo, wi = directions(N, 9), directions(N, 10)
    ev, p = bsdf_eval_pdf(theirs, wo, wi)
    assert_close(ours.eval(wo, wi), ev, what="eval")
    assert_close(ours.pdf(wo, wi), p, what="pdf")
    if kw.get("material") == "Au":        # the mutation: copper's index in place of gold's is caught
        wrong = RoughConductor(alpha=0.25, distribution=dist, sample_visible=False, material="Cu")
        assert not np.allclose(wrong.eval(wo, wi), ev, rtol=1e-3, atol=1e-6)


def test_rough_gold_agrees_with_mitsuba(tmp_path):
    env = _envmap_file(tmp_path)
    ball = ('<shape type="sphere"><point name="center" value="-0.3, 0.5, 0"/><float name="radius" value="0.5"/>'
            '<bsdf type="roughconductor"><string name="material" value="Au"/><string name="distribution" value="ggx"/>'
            '<float name="alpha" value="0.2"/></bsdf></shape>')
    assert_agrees_with_mitsuba(scene(ball + f'<emitter type="envmap"><string name="filename" value="{env}"/>'
                                     '</emitter>'))


# ------------------------------------------------------------------ plastic, dielectric, thindielectric
PLASTICS = {"default": {},
            "int 1.9 nonlinear": {"int_ior": 1.9, "nonlinear": True, "diffuse_reflectance": [0.1, 0.27, 0.36]},
            "bk7 in water": {"int_ior": "bk7", "ext_ior": "water", "diffuse_reflectance": [0.8, 0.2, 0.5],
                             "specular_reflectance": [0.9, 0.5, 0.3]},
            "nonlinear bright": {"int_ior": 1.3, "nonlinear": True, "diffuse_reflectance": [0.95, 0.6, 0.05]}}
DIELECTRICS = {"default": {}, "water in glass": {"int_ior": 1.33, "ext_ior": 1.7, "specular_transmittance": [0.9, 0.5, 0.3]},
               "diamond in water": {"int_ior": "diamond", "ext_ior": "water", "specular_reflectance": [0.4, 0.7, 1.0]},
               "coloured": {"int_ior": 1.2, "specular_reflectance": [0.9, 0.5, 0.3], "specular_transmittance": [0.2, 0.6, 0.9]}}
FAMILIES = {"plastic": (Plastic, PLASTICS), "dielectric": (Dielectric, DIELECTRICS),
            "thindielectric": (ThinDielectric, DIELECTRICS)}
CASES = [(family, name) for family, (_, grid) in FAMILIES.items() for name in grid]


def mitsuba_spec(family: str, kw: dict) -> dict:
    return {"type": family, **{k: {"type": "rgb", "value": v} if isinstance(v, list) else v for k, v in kw.items()}}


def mitsuba_uniforms(bsdf, wo, u):
    """Mitsuba's ``sample(u1, u2)`` arguments for vrlab's ``sample(wo, u)``: u1 = u0 picks the
    lobe (both by its CDF), and the direction uniforms are u0 rescaled into the chosen lobe's
    interval (as :class:`~vrlab.distributions.LobeMixture` passes it on) and u1."""
    P = bsdf.lobe_probabilities(wo)
    cdf = np.cumsum(P, -1)
    k = np.minimum(np.sum(u[:, :1] >= cdf, -1), P.shape[-1] - 1)
    width = np.take_along_axis(P, k[:, None], -1)[:, 0]
    lo = np.take_along_axis(cdf, k[:, None], -1)[:, 0] - width
    u2 = u.copy()
    u2[:, 0] = np.clip((u[:, 0] - lo) / np.where(width > 0, width, 1.0), 0, 1)
    return u[:, 0], u2


def max_rel(a, b, floor=1e-6):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), floor))) if a.size else 0.0


def differences(ours, theirs, family, seed=0, n=N):
    """Largest relative differences from Mitsuba: ``eval``, ``pdf`` on random pairs (upper
    hemisphere for the one-sided plastic, the whole sphere for the dielectrics) and ``sample``'s
    wi (absolute), weight and pdf with the same uniforms.  Sampled rows with wi.z < 0.05 are
    left out of the weight and pdf (float32 Mitsuba's cos theta there is good to ~1e-6
    absolute only; the pairs above cover the values there)."""
    upper = family == "plastic"
    wo, wi = directions(n, seed + 1, upper), directions(n, seed + 2, upper)
    ev, p = bsdf_eval_pdf(theirs, wo, wi)
    u = np.random.default_rng(seed + 3).random((n, 2))
    r = bsdf_sample(theirs, wo, *mitsuba_uniforms(ours, wo, u))
    s_wi, s_w, s_p = ours.sample(wo, u)
    keep = np.abs(r.wi[:, 2]) >= 0.05
    return {"eval": max_rel(ours.eval(wo, wi), ev), "pdf": max_rel(ours.pdf(wo, wi), p),
            "wi": float(np.max(np.abs(s_wi - r.wi))), "weight": max_rel(s_w[keep], r.weight[keep]),
            "sample pdf": max_rel(s_p[keep], r.pdf[keep]), "zero pairs": int(np.sum(ev == 0))}


@pytest.mark.parametrize("family, name", CASES)
def test_smooth_bsdf_values_and_samples_equal_mitsubas(family, name):
    cls, grid = FAMILIES[family]
    d = differences(cls(**grid[name]), mitsuba_bsdf(mitsuba_spec(family, grid[name])), family)
    assert d["eval"] < 1e-4 and d["pdf"] < 1e-4, d
    assert d["wi"] < 5e-6 and d["weight"] < 1e-4 and d["sample pdf"] < 1e-4, d
    if family == "plastic":
        assert d["zero pairs"] == 0                     # the value comparison compares something


class _WrongIOR(Plastic):
    """A plastic whose Fresnel terms use 1 / eta (a mutation that must fail)."""

    def _fresnel(self, c):
        return fresnel_dielectric(c, 1.0 / self.eta).F


_DIELECTRIC_LOBES = Dielectric._lobes


class _NoRadianceScaling(Dielectric):
    """A dielectric without the 1 / eta^2 of transmitted radiance (a mutation that must fail)."""

    def _lobes(self, wo):
        F, wi, scale = _DIELECTRIC_LOBES(self, wo)
        return F, wi, np.ones_like(scale)


MUTATIONS = {
    "plastic 1/eta": (_WrongIOR(int_ior=1.7), {"type": "plastic", "int_ior": 1.7}, "plastic"),
    "plastic int/ext swapped": (Plastic(int_ior="air", ext_ior="polypropylene"), {"type": "plastic"}, "plastic"),
    "dielectric int/ext swapped": (Dielectric(int_ior="air", ext_ior="bk7"), {"type": "dielectric"}, "dielectric"),
    "dielectric without 1/eta^2": (_NoRadianceScaling(), {"type": "dielectric"}, "dielectric"),
    "thindielectric int/ext swapped": (ThinDielectric(int_ior="air", ext_ior="bk7"), {"type": "thindielectric"},
                                       "thindielectric"),
    "thindielectric single interface": (None, {"type": "thindielectric"}, "thindielectric"),
}


class _OneInterface(ThinDielectric):
    """A thin slab that forgets its internal reflections (R' = R): must fail."""

    def _lobes(self, wo):
        return fresnel_dielectric(np.abs(wo[..., 2]), self.eta).F, -wo, np.ones((), wo.dtype)


@pytest.mark.parametrize("name", sorted(MUTATIONS))
def test_wrong_fresnel_terms_fail_the_value_comparison(name):
    ours, spec, family = MUTATIONS[name]
    ours = _OneInterface() if ours is None else ours
    d = differences(ours, mitsuba_bsdf(spec), family, n=200)
    worst = max(d["eval"], d["pdf"], d["weight"], d["sample pdf"])
    assert worst > 1e-2, d
    if family != "plastic":                       # all of a dielectric is in its delta lobes
        assert d["eval"] == d["pdf"] == 0


class _DiffusePart(Distribution):
    """The plastic's continuous part as the mixture samples it: u0 moved into the diffuse
    lobe's interval of the mixture's CDF, pdf = the mixture's pdf / P_d (the whole chain of
    lobe choice, u0 rescaling and mixture density)."""

    dim_u, dim_x, measure = 2, 3, "solid angle"

    def __init__(self, bsdf, wo):
        self.mix = bsdf.distribution(wo)
        self.ps, self.pd = self.mix.probabilities[..., 0], self.mix.probabilities[..., 1]

    def sample(self, u):
        u = np.array(u, float)
        u[..., 0] = self.ps + u[..., 0] * self.pd * (1 - 1e-12)
        wi, k = self.mix.sample_lobe(u)
        assert np.all(k == 1)
        return wi

    def pdf(self, w):
        return self.mix.pdf(w) / self.pd


class _UniformDiffuse(Plastic):
    """A plastic whose pdf claims a uniform hemisphere for its cosine-sampled lobe: must fail."""

    def lobe(self, name, wo):
        if name == "diffuse":
            from vrlab.distributions import UniformHemisphere

            cos = self._cosine
            return type("Wrong", (Distribution,), {"dim_u": 2, "dim_x": 3, "measure": "solid angle",
                                                    "sample": lambda s, u: cos.sample(u),
                                                    "pdf": lambda s, w: UniformHemisphere().pdf(w)})()
        return super().lobe(name, wo)


@pytest.mark.parametrize("theta", [0.3, 1.2])
def test_plastic_diffuse_lobe_passes_chi_square_and_wrong_pdf_fails(theta):
    wo = direction(theta)
    b = Plastic(**PLASTICS["bk7 in water"])
    res = chi2_gof(_DiffusePart(b, wo), HemisphereChart(power=2.0), (24, 24), n=100_000, rng=[5, int(100 * theta)])
    assert_gof(res, m=2)
    bad = chi2_gof(_DiffusePart(_UniformDiffuse(**PLASTICS["bk7 in water"]), wo), HemisphereChart(power=2.0),
                   (24, 24), n=100_000, rng=[6, int(100 * theta)])
    with pytest.raises(AssertionError):
        assert_gof(bad, m=2)


@pytest.mark.parametrize("family, name", CASES)
def test_sample_weights_are_values_over_probabilities(family, name):
    """Continuous rows: weight = eval / pdf; delta rows: pdf = the lobe's probability and weight
    = delta_value / probability; the probabilities sum to 1 where wo is seen (both sides for
    the dielectrics)."""
    cls, grid = FAMILIES[family]
    b = cls(**grid[name])
    wo = directions(N, 11, family == "plastic")
    u = np.random.default_rng(12).random((N, 2))
    wi, weight, pdf = b.sample(wo, u)
    _, k = b.sample_lobe(wo, u)
    P = b.lobe_probabilities(wo)
    assert np.allclose(P.sum(-1), 1.0)
    for i, lobe in enumerate(b.LOBES):
        rows = k == i
        if lobe in b.DELTA:
            d_wi, d_val = b.delta_value(lobe, wo)
            assert np.allclose(pdf[rows], P[rows, i])
            assert np.allclose(weight[rows], d_val[rows] / P[rows, i, None])
            assert np.allclose(wi[rows], d_wi[rows])
        else:
            assert rows.any()
            assert np.allclose(weight[rows], b.eval(wo[rows], wi[rows]) / b.pdf(wo[rows], wi[rows])[:, None])


def test_dielectric_conserves_energy_and_thin_slab_passes_straight_through():
    wo = directions(200, 13, upper=False)
    for eta in (1.5, 1 / 1.33):
        d = Dielectric(int_ior=eta, ext_ior=1.0)
        F = d.lobe_probabilities(wo)[:, 0]
        _, t_val = d.delta_value("transmission", wo)
        eta_it = np.where(wo[:, 2] >= 0, eta, 1 / eta)
        assert np.allclose(F + t_val[:, 0] * eta_it ** 2, 1.0)          # importance is conserved
        wt, _ = d.delta_value("transmission", wo)
        ok = F < 1
        assert np.allclose(np.linalg.norm(wt[ok], axis=-1), 1.0)
        assert np.all(np.sign(wt[ok, 2]) == -np.sign(wo[ok, 2]))           # to the other side
        sin_i = np.linalg.norm(wo[ok, :2], axis=-1)
        assert np.allclose(sin_i, eta_it[ok] * np.linalg.norm(wt[ok, :2], axis=-1))     # Snell
    t = ThinDielectric()
    (_, r), (wt, tv) = t.delta_value("reflection", wo), t.delta_value("transmission", wo)
    assert np.allclose(wt, -wo) and np.allclose(r + tv, 1.0)


def test_plastic_is_one_sided():
    b = Plastic()
    wo = -directions(20, 14)
    wi, weight, pdf = b.sample(wo, np.random.default_rng(0).random((20, 2)))
    assert np.all(weight == 0) and np.all(pdf == 0)
    assert np.all(b.lobe_probabilities(wo) == 0) and np.all(b.delta_value("specular", wo)[1] == 0)
    assert np.all(b.eval(wo, directions(20, 15)) == 0) and np.all(b.eval(-wo, -directions(20, 15)) == 0)
    assert np.all(b.diffuse_albedo() == 0)


def test_plastic_sampling_weight_uses_the_texture_mean_as_mitsuba_does():
    tex = Checkerboard([0.9, 0.1, 0.1], [0.1, 0.1, 0.9])
    ours = Plastic(diffuse_reflectance=tex, specular_reflectance=[0.5, 0.3, 0.4])
    theirs = mitsuba_bsdf({"type": "plastic", "diffuse_reflectance": {"type": "checkerboard",
                           "color0": {"type": "rgb", "value": [0.9, 0.1, 0.1]},
                           "color1": {"type": "rgb", "value": [0.1, 0.1, 0.9]}},
                           "specular_reflectance": {"type": "rgb", "value": [0.5, 0.3, 0.4]}})
    wo = directions(100, 16)
    r = bsdf_sample(theirs, wo, np.zeros(100), np.full((100, 2), 0.5))       # u1 = 0: the specular lobe
    assert np.all(r.sampled_component == 0)
    assert_close(ours.lobe_probabilities(wo)[:, 0], r.pdf, 1e-5, 0, "P_s")


def test_smooth_bsdf_parameters_are_checked(raises_naming):
    for cls in (Plastic, Dielectric, ThinDielectric):
        for bad in (-1.5, 0.0, float("nan"), float("inf"), "unobtainium"):
            with raises_naming(ValueError, "int_ior"):
                cls(int_ior=bad)
            with raises_naming(ValueError, "ext_ior"):
                cls(ext_ior=bad)
        for bad in (None, True, [1.5]):
            with raises_naming(TypeError, "int_ior"):
                cls(int_ior=bad)
        with raises_naming(ValueError, "specular_reflectance"):
            cls(specular_reflectance=-0.1)
    with raises_naming(ValueError, "diffuse_reflectance"):
        Plastic(diffuse_reflectance=[0.5, 0.5])
    with raises_naming(TypeError, "nonlinear"):
        Plastic(nonlinear="yes")
    with raises_naming(ValueError, "specular_transmittance"):
        Dielectric(specular_transmittance=[1.0, float("nan"), 1.0])
    with raises_naming(ValueError, "lobe"):
        Dielectric().delta_value("specular", directions(2, 0))
    assert Dielectric(int_ior="BK7").eta == pytest.approx(1.5046 / 1.000277)
    assert Plastic().eta == pytest.approx(1.49 / 1.000277)


def test_smooth_bsdfs_load_from_xml_and_refuse_unknown_parameters(tmp_path):
    xml = {"plastic": '<bsdf type="plastic"><string name="int_ior" value="bk7"/><float name="ext_ior" value="1.1"/>'
                      '<rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/><rgb name="specular_reflectance" '
                      'value="0.9"/><boolean name="nonlinear" value="true"/></bsdf>',
           "dielectric": '<bsdf type="dielectric"><float name="int_ior" value="1.7"/><string name="ext_ior" '
                         'value="water"/><texture type="checkerboard" name="specular_transmittance"/></bsdf>',
           "thindielectric": '<bsdf type="thindielectric"><rgb name="specular_reflectance" value="0.5"/></bsdf>'}
    for family, body in xml.items():
        sc = load_scene(scene(f'<shape type="sphere">{body}</shape>'))
        b = sc.shapes[-1].bsdf
        assert type(b) is FAMILIES[family][0] and repr(b).startswith(type(b).__name__)
    b = load_scene(scene(f'<shape type="sphere">{xml["plastic"]}</shape>')).shapes[-1].bsdf
    assert b.nonlinear and b.int_ior == "bk7" and b.ext_ior == 1.1 and np.allclose(b.diffuse_reflectance, [0.1, 0.2, 0.3])
    assert isinstance(load_scene(scene(f'<shape type="sphere">{xml["dielectric"]}</shape>')).shapes[-1]
                      .bsdf.specular_transmittance, Checkerboard)
    for family in FAMILIES:
        with pytest.raises(SceneError, match="alpha"):
            load_scene(scene(f'<shape type="sphere"><bsdf type="{family}"><float name="alpha" value="0.1"/></bsdf>'
                             '</shape>'))
    with pytest.raises(SceneError, match="int_ior"):
        load_scene(scene('<shape type="sphere"><bsdf type="dielectric"><string name="int_ior" value="nope"/></bsdf>'
                         '</shape>'))


# ------------------------------------------------------------------ images of the smooth BSDFs
BALL = '<shape type="sphere"><point name="center" value="-0.3, 0.5, 0"/><float name="radius" value="0.5"/>'
PANE = ('<shape type="rectangle">{flip}<transform name="to_world"><scale x="0.9" y="0.7"/><rotate y="1" angle="25"/>'
        '<translate x="0.4" y="0.8" z="1.2"/></transform>{bsdf}</shape>')
SMOOTH_SCENES = {
    "plastic ball": BALL + '<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.2, 0.5, 0.8"/>'
                           '<float name="int_ior" value="1.7"/></bsdf></shape>' + EMITTERS["constant"],
    "plastic ball nonlinear textured": BALL + '<bsdf type="plastic"><boolean name="nonlinear" value="true"/>'
                                              '<texture type="checkerboard" name="diffuse_reflectance"><rgb name="color0" '
                                              'value="0.9, 0.5, 0.1"/><transform name="to_uv"><scale value="4"/>'
                                              '</transform></texture></bsdf></shape>',
    "glass ball around a light": BALL + '<bsdf type="dielectric"/></shape><shape type="sphere"><point name="center" '
                                        'value="-0.3, 0.5, 0"/><float name="radius" value="0.2"/><emitter type="area">'
                                        '<rgb name="radiance" value="4, 2, 1"/></emitter></shape>',
    "glass pane from behind": PANE.format(flip='<boolean name="flip_normals" value="true"/>',
                                          bsdf='<bsdf type="dielectric"><float name="int_ior" value="1.5"/></bsdf>')
                              + EMITTERS["constant"],
    "thin pane": PANE.format(flip="", bsdf='<bsdf type="thindielectric"><rgb name="specular_transmittance" '
                                           'value="0.9, 0.6, 0.3"/></bsdf>'),
}


# every family once (the plain plastic ball, whose image the textured nonlinear one covers, serves
# the refusal test)
@pytest.mark.parametrize("name", sorted(set(SMOOTH_SCENES) - {"plastic ball"}))
def test_smooth_bsdf_images_agree_with_mitsuba(name):
    """Lights reflected by the plastic's coating and seen through (refracted by) the glass: a
    light inside a glass ball, panes of one interface seen from either side, a thin slab."""
    assert_agrees_with_mitsuba(scene(SMOOTH_SCENES[name]), estimator="mis-power")


def test_glass_without_radiance_scaling_fails_the_image_criterion(monkeypatch):
    """The light inside the glass ball, rendered without the 1 / eta^2 of transmitted radiance,
    fails against the reference of the right scene."""
    xml = scene(SMOOTH_SCENES["glass ball around a light"])
    spp = max(1, sample_budget() // (W * H))
    reference = (*mitsuba_reference(xml, 4 * spp), 4 * spp)
    assert_agrees_with_mitsuba(xml, estimator="mis-power", reference=reference)
    monkeypatch.setattr(Dielectric, "_lobes", _NoRadianceScaling._lobes)
    with pytest.raises(AssertionError):
        assert_agrees_with_mitsuba(xml, estimator="mis-power", reference=reference)


@pytest.mark.parametrize("name", ["plastic ball", "glass ball around a light", "thin pane"])
def test_light_sampling_alone_is_refused_on_smooth_bsdfs(raises_naming, name):
    sc = load_scene(scene(SMOOTH_SCENES[name]))
    family = {"plastic ball": "plastic", "glass ball around a light": "dielectric", "thin pane": "thindielectric"}[name]
    with raises_naming(ValueError, "estimator", family):
        render(sc, 1, "light", width=4, height=3)


# ------------------------------------------------------------------ normalmap
def _normal_map(tmp_path, seed=0):
    """A 16 x 16 PNG of tilted normals (up to ~35 degrees), encoded (n + 1) / 2."""
    from PIL import Image

    g = np.random.default_rng(seed)
    n = np.concatenate([g.uniform(-0.5, 0.5, (16, 16, 2)), np.ones((16, 16, 1))], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    Image.fromarray(np.round((n + 1) / 2 * 255).astype(np.uint8)).save(tmp_path / "normals.png")
    return tmp_path / "normals.png"


def _normalmap_scene(path, inner='<bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.5, 0.3"/></bsdf>'):
    nm = (f'<bsdf type="normalmap"><texture type="bitmap" name="normalmap"><string name="filename" value="{path}"/>'
          f'<boolean name="raw" value="true"/></texture>{inner}</bsdf>')
    return scene('<shape type="sphere"><point name="center" value="-0.3, 0.5, 0"/><float name="radius" value="0.5"/>'
                 f'{nm}</shape>' + EMITTERS["point"]).replace(
        '<transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform><bsdf type="diffuse">'
        '<rgb name="reflectance" value="0.6, 0.5, 0.4"/></bsdf>',
        f'<transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/><rotate y="1" angle="30"/>'
        f'</transform>{nm}')


@pytest.mark.parametrize("inner", ["diffuse", "roughconductor", "plastic"])
def test_normalmap_values_equal_mitsubas(inner):
    from vrlab.render.bsdfs.diffuse import Diffuse
    from vrlab.render.bsdfs.normalmap import NormalMap
    from vrlab.render.bsdfs.roughconductor import RoughConductor

    ours_inner, spec = {"diffuse": (Diffuse([0.3, 0.6, 0.2]), {"type": "diffuse", "reflectance": {
                            "type": "rgb", "value": [0.3, 0.6, 0.2]}}),
                        "roughconductor": (RoughConductor(alpha=0.2, distribution="ggx", sample_visible=False),
                                           {"type": "roughconductor", "alpha": 0.2, "distribution": "ggx",
                                            "sample_visible": False}),
                        "plastic": (Plastic(), {"type": "plastic"})}[inner]
    for c in ([0.6, 0.45, 0.85], [0.3, 0.7, 0.7], [0.5, 0.5, 1.0]):
        ours = NormalMap(ours_inner, c)
        theirs = mitsuba_bsdf({"type": "normalmap", "normalmap": {"type": "rgb", "value": c}, "nested": spec})
        wo, wi = directions(N, 11), directions(N, 12, upper=False)
        ev, p = bsdf_eval_pdf(theirs, wo, wi)
        assert_close(ours.eval(wo, wi), ev, what=f"eval {c}")
        seen = ev.sum(-1) > 0            # Mitsuba's pdf is 0 where the side test cuts; vrlab's is the sampler's
        assert_close(ours.pdf(wo, wi)[seen], p[seen], what=f"pdf {c}")


def test_normalmap_images_agree_with_mitsuba(tmp_path):
    xml = _normalmap_scene(_normal_map(tmp_path))
    assert xml.count('type="normalmap"') == 2               # the sphere and the turned floor
    assert_agrees_with_mitsuba(xml)


def test_a_normal_map_read_in_the_wrong_tangent_frame_fails(tmp_path, monkeypatch):
    """The tilted frame's s must follow dp/du: a frame turned by 90 degrees (s along dp/dv)
    renders a different image, which Mitsuba's criterion rejects."""
    from vrlab.render.shading import ShadingIntegrand

    xml = _normalmap_scene(_normal_map(tmp_path))
    spp = 4 * max(1, sample_budget() // (W * H))
    ref = mitsuba_reference(xml, spp)
    tangent_frame = ShadingIntegrand._tangent_frame

    def turned(ns, flip, dp_du, dp_dv):
        return tangent_frame(ns, flip, dp_dv, dp_du)

    monkeypatch.setattr(ShadingIntegrand, "_tangent_frame", staticmethod(turned))
    with pytest.raises(AssertionError):
        assert_agrees_with_mitsuba(xml, reference=(*ref, spp))


def _rawconstant_normalmap_scene():
    """An anisotropic rough conductor under a constant normal map (``rawconstant``) on a sphere and
    a turned rectangle: the nested BSDF sees the tilted frame's tangent s'."""
    inner = ('<bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha_u" '
             'value="0.05"/><float name="alpha_v" value="0.4"/></bsdf>')
    nm = ('<bsdf type="normalmap"><texture type="rawconstant" name="normalmap"><vector name="value" x="0.6" y="0.45" '
          f'z="0.85"/></texture>{inner}</bsdf>')
    body = (f'<shape type="sphere"><point name="center" value="-0.3, 0.5, 0"/><float name="radius" value="0.5"/>{nm}'
            '</shape><shape type="rectangle"><transform name="to_world"><scale value="0.6"/><rotate x="1" angle="-70"/>'
            f'<rotate y="1" angle="30"/><translate x="0.6" y="0.5"/></transform>{nm}</shape>')
    return scene(body + EMITTERS["point"])


def test_normal_mapped_anisotropic_metal_agrees_with_mitsuba(monkeypatch):
    """Mitsuba 3.9.1 builds the tilted frame's s' from the shading frame's own x axis (dp/du made
    orthogonal to n): the world dp/du read as local coordinates (vrlab's frame before) made this
    scene 2-8 % too bright; s' from the y axis fails too."""
    import vrlab.render.bsdfs.normalmap as normalmap

    xml = _rawconstant_normalmap_scene()
    spp = 4 * max(1, sample_budget() // (W * H))
    reference = (*mitsuba_reference(xml, spp), spp)
    assert_agrees_with_mitsuba(xml, reference=reference)
    monkeypatch.setattr(normalmap, "_X", np.array([0.0, 1.0, 0.0]))
    with pytest.raises(AssertionError):
        assert_agrees_with_mitsuba(xml, reference=reference)


def test_rawconstant_values_equal_mitsubas(raises_naming):
    """``rawconstant``: a float or 3-vector kept as it is (no colour conversion), Mitsuba's eval,
    eval_1 (refused for a 3-vector) and mean; as a normal map, values equal Mitsuba's."""
    import mitsuba as mi

    from vrlab.render.bsdfs.normalmap import NormalMap
    from vrlab.render.bsdfs.roughconductor import RoughConductor
    from vrlab.render.textures.rawconstant import RawConstant

    uv = np.zeros((4, 2))
    for value in ([0.6, 0.45, 1.85], [-0.5, 2.0, 3.0], 0.3):
        ours = RawConstant(value)
        with mi.util.scoped_set_variant("scalar_rgb"):
            theirs = mi.load_dict({"type": "rawconstant", "value": value})
            si = mi.SurfaceInteraction3f()
            np.testing.assert_allclose(ours.eval(uv)[0], np.array(theirs.eval_3(si)), rtol=1e-6)
            np.testing.assert_allclose(ours.mean_1(), float(theirs.mean()), rtol=1e-6)
            if np.ndim(value) == 0:
                np.testing.assert_allclose(ours.eval_1(uv), float(theirs.eval_1(si)), rtol=1e-6)
    with raises_naming(ValueError, "eval_1"):
        RawConstant([0.1, 0.2, 0.3]).eval_1(uv)
    for bad in (float("nan"), [0.1, 0.2], None):
        with pytest.raises((ValueError, TypeError), match="value"):
            RawConstant(bad)
    with pytest.raises(SceneError, match="value"):      # Mitsuba refuses an <rgb> value too
        load_scene(scene('<shape type="sphere"><bsdf type="normalmap"><texture type="rawconstant" name="normalmap">'
                         '<rgb name="value" value="0.5, 0.5, 1"/></texture><bsdf type="diffuse"/></bsdf></shape>'))
    inner = RoughConductor(distribution="ggx", alpha_u=0.05, alpha_v=0.4, material="Cu")
    spec = {"type": "roughconductor", "distribution": "ggx", "alpha_u": 0.05, "alpha_v": 0.4, "material": "Cu"}
    ours = NormalMap(inner, RawConstant([0.6, 0.45, 0.85]))
    theirs = mitsuba_bsdf({"type": "normalmap", "normalmap": {"type": "rawconstant", "value": [0.6, 0.45, 0.85]},
                           "nested": spec})
    wo, wi = directions(N, 31), directions(N, 32, upper=False)
    ev, _ = bsdf_eval_pdf(theirs, wo, wi)
    assert_close(ours.at({"normalmap": np.array([0.6, 0.45, 0.85])}).eval(wo, wi), ev, what="eval")


# ------------------------------------------------------------------ roughconductor: visible normals, anisotropy
ROUGH_CASES = {
    "ggx iso": {"distribution": "ggx", "alpha": 0.3},
    "ggx aniso": {"distribution": "ggx", "alpha_u": 0.08, "alpha_v": 0.5},
    "beckmann iso": {"distribution": "beckmann", "alpha": 0.25},
    "beckmann aniso": {"distribution": "beckmann", "alpha_u": 0.4, "alpha_v": 0.1},
}


@pytest.mark.parametrize("visible", [True, False])
@pytest.mark.parametrize("name", sorted(ROUGH_CASES))
def test_roughconductor_values_and_samples_equal_mitsubas(name, visible):
    """eval to 1e-4; pdf to 1e-4 except Beckmann's visible normals, where Mitsuba's reported
    pdf uses its rational G1 and is not the density it samples (vrlab's is: within 0.35 %);
    the same uniforms give the same direction (Mitsuba's u2 is vrlab's u)."""
    from vrlab.render.bsdfs.roughconductor import RoughConductor

    kw = ROUGH_CASES[name]
    ours = RoughConductor(**kw, material="Cu", sample_visible=visible)
    theirs = mitsuba_bsdf({"type": "roughconductor", "material": "Cu", "sample_visible": visible, **kw})
    wo, wi = directions(N, 21), directions(N, 22)
    ev, p = bsdf_eval_pdf(theirs, wo, wi)
    assert_close(ours.eval(wo, wi), ev, what="eval")
    loose = visible and kw["distribution"] == "beckmann"
    assert_close(ours.pdf(wo, wi), p, 3.5e-3 if loose else 1e-4, what="pdf")
    u = np.random.default_rng(23).random((N, 2))
    r = bsdf_sample(theirs, wo, np.zeros(N), u)
    swi, _, _ = ours.sample(wo, u)
    ok = (r.pdf > 0) & (wo[:, 2] > 0.05)                 # Mitsuba's float32 azimuth near the pole
    assert_close(swi[ok], r.wi[ok], 0, 2e-4 if loose else 1e-4, "sampled wi")
    if "aniso" in name:                                  # the roughness axes are not interchangeable
        swapped = RoughConductor(distribution=kw["distribution"], alpha_u=kw["alpha_v"], alpha_v=kw["alpha_u"],
                                 material="Cu", sample_visible=visible)
        assert not np.allclose(swapped.eval(wo, wi), ev, rtol=1e-3, atol=1e-6)


def test_anisotropic_rough_metal_agrees_with_mitsuba():
    """Anisotropic roughness follows dp/du: a sphere (dp/du along its parallels) and a turned
    floor, lit by a point light and two area lights."""
    ball = ('<shape type="sphere"><point name="center" value="-0.3, 0.5, 0"/><float name="radius" value="0.5"/>'
            '<bsdf type="roughconductor"><string name="material" value="Al"/><string name="distribution" '
            'value="ggx"/><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.4"/></bsdf></shape>')
    xml = scene(ball + EMITTERS["point"])
    assert_agrees_with_mitsuba(xml)


# ------------------------------------------------------------------ mask
@pytest.mark.parametrize("opacity", [0.0, 0.3, 1.0])
def test_mask_values_and_null_samples_equal_mitsubas(opacity):
    from vrlab.render.bsdfs.diffuse import Diffuse
    from vrlab.render.bsdfs.mask import Mask

    ours = Mask(Diffuse([0.1, 0.8, 0.1]), opacity)
    theirs = mitsuba_bsdf({"type": "mask", "opacity": opacity,
                           "nested": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.1, 0.8, 0.1]}}})
    wo, wi = directions(N, 31), directions(N, 32)
    ev, p = bsdf_eval_pdf(theirs, wo, wi)
    assert_close(ours.eval(wo, wi), ev, what="eval")
    assert_close(ours.pdf(wo, wi), p, what="pdf")
    u = np.random.default_rng(33).random((N, 2))
    r = bsdf_sample(theirs, wo, u[:, 0], u)
    wi_s, weight, pdf = ours.sample(wo, u)
    null = np.isclose(wi_s, -wo).all(-1)                  # straight through: probability 1 - opacity, weight 1
    assert np.mean(null) == pytest.approx(1 - opacity, abs=0.06)
    assert np.allclose(pdf[null], 1 - opacity) and np.allclose(weight[null], 1.0)
    assert_close(weight[null], r.weight[null], 0, 1e-6, "null weight")
    assert ours.LOBES == ("diffuse", "null") and ours.DELTA == ("null",)


def test_a_mask_shows_the_light_behind_it_as_mitsuba_does():
    """A checkerboard-masked panel between the camera and the sphere light: the light is seen
    through the open squares (the null lobe, reached by BSDF sampling only)."""
    panel = ('<shape type="rectangle"><transform name="to_world"><scale x="0.9" y="0.6"/><rotate y="1" angle="20"/>'
             '<translate x="0.6" y="0.8" z="1.2"/></transform><bsdf type="mask"><texture type="checkerboard" '
             'name="opacity"><rgb name="color0" value="0.15"/><rgb name="color1" value="0.9"/><transform '
             'name="to_uv"><scale value="4"/></transform></texture><bsdf type="twosided"><bsdf type="diffuse">'
             '<rgb name="reflectance" value="0.1, 0.8, 0.1"/></bsdf></bsdf></bsdf></shape>')
    assert_agrees_with_mitsuba(scene(panel + EMITTERS["constant"]))
    with pytest.raises(ValueError, match="null"):
        render(load_scene(scene(panel)), 1, "light", width=4, height=3)


# ------------------------------------------------------------------ bumpmap
def _height_map(tmp_path, seed=0):
    from PIL import Image

    img = (np.random.default_rng(seed).random((8, 8)) * 255).astype(np.uint8)
    Image.fromarray(img).save(tmp_path / "height.png")
    return tmp_path / "height.png"


@pytest.mark.parametrize("scale", [0.05, 0.3])
@pytest.mark.parametrize("wrap", ["repeat", "mirror"])
def test_bumpmap_values_and_texture_gradients_equal_mitsubas(tmp_path, scale, wrap):
    from vrlab.render.bsdfs.bumpmap import BumpMap
    from vrlab.render.bsdfs.diffuse import Diffuse
    from vrlab.render.textures.bitmap import BitmapTexture

    path = _height_map(tmp_path)
    tex = BitmapTexture(path, raw=True, wrap_mode=wrap)
    uv = np.random.default_rng(41).random((N, 2)) * 2 - 0.5
    grad = tex.eval_1_grad(uv)
    spec = {"type": "bitmap", "filename": str(path), "raw": True, "wrap_mode": wrap}
    import mitsuba as mi

    mt, si = mi.load_dict(spec), mi.SurfaceInteraction3f()
    theirs_grad = []
    for p in uv:
        si.uv = mi.Point2f(*p)
        theirs_grad.append(np.array(mt.eval_1_grad(si)))
    assert_close(grad, np.array(theirs_grad), 1e-4, 1e-4, "eval_1_grad")
    ours = BumpMap(Diffuse([0.3, 0.6, 0.2]), tex, scale).at({"texture": grad})
    theirs = mitsuba_bsdf({"type": "bumpmap", "scale": scale, "height": spec,
                           "nested": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.3, 0.6, 0.2]}}})
    wo, wi = directions(N, 42), directions(N, 43)
    ev, _ = bsdf_eval_pdf(theirs, wo, wi, uv=uv)
    assert_close(ours.eval(wo, wi), ev, what="eval")
    flat = BumpMap(Diffuse([0.3, 0.6, 0.2]), tex, 0.0).at({"texture": grad})     # no bump: not the same
    assert not np.allclose(flat.eval(wo, wi), ev, rtol=1e-3, atol=1e-6)


def test_bumpmap_images_agree_with_mitsuba(tmp_path):
    path = _height_map(tmp_path)
    bump = (f'<bsdf type="bumpmap"><float name="scale" value="0.02"/><texture type="bitmap"><string name="filename" '
            f'value="{path}"/><boolean name="raw" value="true"/></texture><bsdf type="roughconductor">'
            '<string name="material" value="Cu"/><float name="alpha" value="0.2"/></bsdf></bsdf>')
    xml = scene('<shape type="sphere"><point name="center" value="-0.3, 0.5, 0"/><float name="radius" value="0.5"/>'
                f'{bump}</shape>' + EMITTERS["point"])
    assert_agrees_with_mitsuba(xml)


# ------------------------------------------------------------------ delta lobes under every estimator
def test_delta_lobes_stay_unbiased_under_every_estimator():
    """A plastic ball (a delta coating over a diffuse base) and a gold mirror under an area
    light and a sky: estimators that sample the BSDF agree with mis-power on the image mean,
    including MIS over the plastic's lobes as separate techniques."""
    from vrlab.estimators import MIS, RIS, Antithetic, DefensiveMixture, OneSampleMIS

    xml = scene('<shape type="sphere"><point name="center" value="-0.3, 0.5, 0"/><float name="radius" value="0.5"/>'
                '<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.3, 0.5, 0.2"/></bsdf></shape>'
                '<shape type="sphere"><point name="center" value="0.7, 0.35, 0.4"/><float name="radius" value="0.3"/>'
                '<bsdf type="conductor"><string name="material" value="Au"/></bsdf></shape>' + EMITTERS["constant"])
    sc = load_scene(xml)
    base = render(sc, 256, "mis-power", rng=1)
    m0, s0 = image_mean(base.value, base.stderr)
    estimators = {
        "bsdf": "bsdf", "mixture": "mixture", "mis-balance": "mis-balance", "mis-optimal": "mis-optimal",
        "one-sample": OneSampleMIS(["bsdf", "light"]), "antithetic": Antithetic("bsdf"),
        "defensive": DefensiveMixture(["light", "bsdf"]), "ris": RIS("bsdf", target="unshadowed", m=4),
    }
    for name, est in estimators.items():
        e = render(sc, 256, est, rng=2)
        m, s = image_mean(e.value, e.stderr)
        assert np.all(np.abs(m - m0) < 4.5 * np.hypot(s, s0)), (name, m, m0, s, s0)
    # MIS over lobes needs a scene whose every BSDF has them: the plastic ball alone
    lobes = load_scene(xml.replace('<bsdf type="conductor"><string name="material" value="Au"/></bsdf>',
                                   '<bsdf type="plastic"/>'))
    a = render(lobes, 256, MIS(["light", "bsdf:diffuse", "bsdf:specular"], heuristic="balance"), rng=3)
    b = render(lobes, 256, "mis-power", rng=4)
    ma, sa = image_mean(a.value, a.stderr)
    mb, sb = image_mean(b.value, b.stderr)
    assert np.all(np.abs(ma - mb) < 4.5 * np.hypot(sa, sb)), (ma, mb)


# ------------------------------------------------------------------ roughplastic, roughdielectric
ROUGH_PLASTICS = {
    "default": {},
    "ggx 0.3": {"distribution": "ggx", "alpha": 0.3},
    "beckmann full ndf, 1.9": {"alpha": 0.5, "int_ior": 1.9, "sample_visible": False,
                                "diffuse_reflectance": [0.1, 0.27, 0.36]},
    "ggx bk7 in water nonlinear": {"distribution": "ggx", "alpha": 0.05, "int_ior": "bk7", "ext_ior": "water",
                                   "nonlinear": True, "diffuse_reflectance": [0.9, 0.3, 0.1],
                                   "specular_reflectance": [0.9, 0.5, 0.3]},
    "beckmann eta < 1": {"alpha": 0.2, "int_ior": 1.2, "ext_ior": 1.5},
}
ROUGH_DIELECTRICS = {
    "default": {},
    "ggx 0.3": {"distribution": "ggx", "alpha": 0.3},
    "ggx aniso water": {"distribution": "ggx", "alpha_u": 0.1, "alpha_v": 0.4, "int_ior": "water"},
    "beckmann aniso diamond in water": {"distribution": "beckmann", "alpha_u": 0.4, "alpha_v": 0.15,
                                        "int_ior": "diamond", "ext_ior": "water",
                                        "specular_transmittance": [0.9, 0.5, 0.2]},
    "ggx full ndf": {"distribution": "ggx", "alpha": 0.3, "sample_visible": False,
                     "specular_reflectance": [0.8, 0.6, 1.0]},
    "beckmann full ndf, eta < 1": {"alpha": 0.3, "sample_visible": False, "int_ior": 1.2, "ext_ior": 1.6},
}


def _rough_pair(family, kw):
    from vrlab.render.bsdfs.roughdielectric import RoughDielectric
    from vrlab.render.bsdfs.roughplastic import RoughPlastic

    cls = RoughPlastic if family == "roughplastic" else RoughDielectric
    return cls(**kw), mitsuba_bsdf(mitsuba_spec(family, kw))


def _beckmann_visible(kw):
    return kw.get("distribution", "beckmann") == "beckmann" and kw.get("sample_visible", True)


@pytest.mark.parametrize("name", sorted(ROUGH_PLASTICS))
def test_roughplastic_values_and_samples_equal_mitsubas(name):
    """eval and pdf to 1e-4 (pdf to 3.5e-3 for Beckmann's visible normals, whose pdf Mitsuba
    reports with its rational G1: not the density of its samples, which vrlab's is); the same
    uniforms give the same direction (the lobe chosen by u0 as Mitsuba's sample1, the rescaled u0
    and u1 as its sample2: ``mitsuba_uniforms``) and weight = eval / pdf."""
    kw = ROUGH_PLASTICS[name]
    ours, theirs = _rough_pair("roughplastic", kw)
    loose = 3.5e-3 if _beckmann_visible(kw) else 1e-4
    wo, wi = directions(N, 31), directions(N, 32)
    ev, p = bsdf_eval_pdf(theirs, wo, wi)
    assert (ev.sum(-1) > 0).mean() > 0.7                   # the comparison compares something
    assert_close(ours.eval(wo, wi), ev, what="eval")
    assert_close(ours.pdf(wo, wi), p, loose, what="pdf")
    u = np.random.default_rng(33).random((N, 2))
    r = bsdf_sample(theirs, wo, *mitsuba_uniforms(ours, wo, u))
    wi_s, weight, pdf = ours.sample(wo, u)
    ok = r.pdf > 0
    assert ok.mean() > 0.8
    assert_close(wi_s[ok], r.wi[ok], 0, 1e-4, "sampled wi")
    keep = ok & (r.wi[:, 2] > 0.05)
    assert_close(pdf[keep], r.pdf[keep], loose, what="sample pdf")
    assert_close(weight[keep], r.weight[keep], loose, 1e-6, "weight")
    pos = pdf > 0
    assert_close(weight[pos], ours.eval(wo, wi_s)[pos] / pdf[pos, None], 1e-10, 0, "weight = eval / pdf")
    k = ours.sample_lobe(wo, u)[1]
    assert np.all(k[ok] == r.sampled_component[ok])


def test_roughplastic_tables_equal_mitsubas():
    """The rough transmittance table T(mu) and internal reflectance F_int that Mitsuba integrates
    when it builds a roughplastic, read back from its diffuse lobe (R_s = 0, R_d = 1: eval =
    T(cos theta_o) T(cos theta_i) cos theta_i / (pi eta^2 (1 - F_int))), at the table's cosines."""
    from vrlab.render.bsdfs.roughplastic import TABLE_SIZE

    for kw in ({"int_ior": 1.5}, {"int_ior": 1.2, "ext_ior": 1.5, "distribution": "ggx", "alpha": 0.4}):
        kw = {**kw, "specular_reflectance": 0.0, "diffuse_reflectance": 1.0}
        ours, theirs = _rough_pair("roughplastic", kw)
        mu = np.maximum(1e-6, np.linspace(0, 1, TABLE_SIZE))[1:]
        v = np.stack([np.sqrt(1 - mu ** 2), 0 * mu, mu], -1)
        n = np.array([[0, 0, 1.0]])
        ev, _ = bsdf_eval_pdf(theirs, v, n)
        e1, _ = bsdf_eval_pdf(theirs, n, n)
        T1 = np.sqrt(e1[0, 0] * np.pi * ours.eta ** 2 * (1 - ours.internal_reflectance))
        assert T1 == pytest.approx(ours.transmittance[-1], rel=2e-6)
        assert_close(ev[:, 0] / e1[0, 0] * T1, ours.transmittance[1:], 1e-5, 1e-6, "T(mu)")
        assert 0 < ours.internal_reflectance < 1


def _rough_dielectric_differences(ours, theirs, n=N, seed=41):
    """vrlab against Mitsuba on the whole sphere: eval; pdf where both are the same quantity
    (Mitsuba counts the reflection branch alone for wi on wo's side and the transmission term of
    wo's index alone across; vrlab's pdf adds the branches: ``branch_terms`` gives them apart);
    samples with the same uniforms (u[..., :2] = Mitsuba's sample2, u[..., 2] = its sample1).
    Pairs whose refraction is within 1e-3 of grazing the microfacet are left out of the values:
    Mitsuba's float32 Fresnel term is ill-conditioned there (its 1 - F and cos theta_t cancel;
    e.g. 0 against 4.6e-7)."""
    wo, wi = directions(n, seed, False), directions(n, seed + 1, False)
    ev, p = bsdf_eval_pdf(theirs, wo, wi)
    p_r, p_t, _ = ours.branch_terms(wo, wi)
    same = wo[:, 2] * wi[:, 2] > 0
    eta_o = np.where(wo[:, 2] > 0, ours.eta, 1 / ours.eta)
    m = wo + np.where(same, 1.0, eta_o)[:, None] * wi
    m /= np.linalg.norm(m, axis=-1, keepdims=True)
    stable = same | (np.abs(np.sum(wi * m, -1)) > 1e-3)
    u = np.random.default_rng(seed + 2).random((n, 3))
    r = bsdf_sample(theirs, wo, u[:, 2], u[:, :2])
    wi_s, weight, pdf = ours.sample(wo, u)
    ok = r.pdf > 0
    # weights where the sample's branch alone produces wi and eval uses that branch's formula
    sr, st, so = ours.branch_terms(wo, wi_s)
    refl = r.sampled_component == 0
    side = wi_s[:, 2] * wo[:, 2] > 0
    clean = ok & np.where(refl, side & (st + so == 0), ~side & (sr + so == 0)) & (np.abs(wi_s[:, 2]) > 0.05)
    return {"eval": max_rel(ours.eval(wo, wi)[stable], ev[stable]),
            "pdf": max_rel(np.where(same, p_r, p_t)[stable], p[stable]),
            "stable": float(stable.mean()), "both sides": (same.mean(), (~same & (ev.sum(-1) > 0)).mean()),
            "wi": float(np.max(np.abs(wi_s - r.wi)[ok])), "ok": float(ok.mean()),
            "weight": max_rel(weight[clean], r.weight[clean]), "clean": float(clean.mean()),
            "sample pdf": max_rel(np.where(refl, sr, st)[clean], r.pdf[clean]),
            "eval/pdf": max_rel(weight[pdf > 0], ours.eval(wo, wi_s)[pdf > 0] / pdf[pdf > 0, None])}


@pytest.mark.parametrize("name", sorted(ROUGH_DIELECTRICS))
def test_roughdielectric_values_and_samples_equal_mitsubas(name):
    """eval to 1e-4 on both sides, pdf branch by branch to 1e-4 (3.5e-3 for Beckmann's visible
    normals: Mitsuba's rational G1); sampled directions equal Mitsuba's for the same uniforms; the
    weight is eval / pdf and equals Mitsuba's where one branch alone produces the sample.  With
    ``sample_visible=false`` Mitsuba 3.9.1's sample weight is not its eval / pdf (it leaves out
    D / D' of Walter's widened sampling roughness), so there the weight is only checked as eval / pdf."""
    kw = ROUGH_DIELECTRICS[name]
    ours, theirs = _rough_pair("roughdielectric", kw)
    d = _rough_dielectric_differences(ours, theirs)
    loose = 3.5e-3 if _beckmann_visible(kw) else 1e-4
    assert d["stable"] > 0.97 and min(d["both sides"]) > 0.015, d      # both branches, both sides compared
    assert d["eval"] < 1e-4 and d["pdf"] < loose, d
    assert d["wi"] < (2e-4 if loose > 1e-4 else 5e-5) and d["ok"] > 0.9, d
    assert d["eval/pdf"] < 1e-9, d
    if kw.get("sample_visible", True):
        assert d["clean"] > 0.5 and d["weight"] < loose and d["sample pdf"] < loose, d
    else:
        assert d["sample pdf"] < 1e-3, d


def test_roughdielectric_sees_the_inside_with_the_inverted_index():
    from vrlab.render.bsdfs.roughdielectric import RoughDielectric

    a, b = RoughDielectric(0.2, "ggx", int_ior=1.5, ext_ior=1.0), RoughDielectric(0.2, "ggx", int_ior=1.0, ext_ior=1.5)
    wo, wi = directions(200, 51), directions(200, 52, False)
    flip = np.array([1, 1, -1.0])
    # the same interface seen from the other side: swap the media and mirror both directions
    np.testing.assert_allclose(a.eval(wo * flip, wi * flip), b.eval(wo, wi), rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(a.pdf(wo * flip, wi * flip), b.pdf(wo, wi), rtol=1e-10, atol=1e-14)


class _RoughWrongIOR:
    """Mutations that must fail the value comparison: the Fresnel term with 1 / eta, and the
    transmission Jacobian without its factor eta_o^2 (in eval and in the density)."""

    @staticmethod
    def plastic():
        from vrlab.render.bsdfs import roughplastic

        class WrongIOR(roughplastic.RoughPlastic):
            def eval(self, wo, wi):
                eta, self.eta = self.eta, 1.0 / self.eta
                try:
                    return super().eval(wo, wi)
                finally:
                    self.eta = eta
        return WrongIOR

    @staticmethod
    def dielectric_fresnel():
        from vrlab.render.bsdfs import roughdielectric

        class WrongIOR(roughdielectric.RoughDielectric):
            def eval(self, wo, wi):
                fresnel = roughdielectric.fresnel_dielectric
                roughdielectric.fresnel_dielectric = lambda c, eta: fresnel(c, 1.0 / eta)
                try:
                    return super().eval(wo, wi)
                finally:
                    roughdielectric.fresnel_dielectric = fresnel
        return WrongIOR


class _NoEtaJacobian:
    """A roughdielectric whose transmission density drops the e^2 of the refraction Jacobian."""

    @staticmethod
    def make(**kw):
        from vrlab.render.bsdfs.roughdielectric import RoughDielectric

        class NoEta(RoughDielectric):
            def branch_terms(self, wo, wi, mode="mixture"):
                p_r, p_same, p_other = super().branch_terms(wo, wi, mode)
                wo, wi = np.broadcast_arrays(wo, wi)
                e2 = np.where(wo[..., 2] > 0, self.eta, 1 / self.eta) ** 2
                return p_r, p_same / e2, p_other * e2
        return NoEta(**kw)


def test_wrong_rough_fresnel_terms_and_jacobians_fail():
    kw = ROUGH_PLASTICS["ggx 0.3"]
    ours, theirs = _rough_pair("roughplastic", kw)
    wrong = _RoughWrongIOR.plastic()(**kw)
    wo, wi = directions(200, 61), directions(200, 62)
    ev, _ = bsdf_eval_pdf(theirs, wo, wi)
    assert max_rel(ours.eval(wo, wi), ev) < 1e-4 and max_rel(wrong.eval(wo, wi), ev) > 1e-2
    kw = ROUGH_DIELECTRICS["ggx 0.3"]
    ours, theirs = _rough_pair("roughdielectric", kw)
    assert _rough_dielectric_differences(_RoughWrongIOR.dielectric_fresnel()(**kw), theirs, n=200)["eval"] > 1e-2
    d = _rough_dielectric_differences(_NoEtaJacobian.make(**kw), theirs, n=200)
    assert d["pdf"] > 0.1 and d["sample pdf"] > 0.1, d


def test_roughdielectric_lobes_sample_one_branch_each():
    """``lobe("reflection")`` always reflects, ``lobe("transmission")`` refracts (reflects at
    total internal reflection); each lobe's pdf is its density (tests/test_bsdfs.py runs the
    chi-square tests), and ``distribution`` is Mitsuba's sampler with dim_u = 3."""
    from vrlab.render.bsdfs.roughdielectric import RoughDielectric

    b = RoughDielectric(0.3, "ggx")
    wo = np.array([direction(0.7), -direction(0.4), -direction(1.2)])[:, None, :]
    u = np.random.default_rng(0).random((3, 2000, 2))
    wr = b.lobe("reflection", wo).sample(u)
    wt = b.lobe("transmission", wo).sample(u)
    assert np.mean(wr[..., 2] * wo[..., 2] > 0) > 0.85
    assert np.mean(wt[0, :, 2] < 0) > 0.85 and np.mean(wt[1, :, 2] > 0) > 0.85
    assert 0.2 < np.mean(wt[2, :, 2] < 0) < 0.9          # beyond the critical angle: mostly reflected
    assert b.distribution(wo).dim_u == 3 and b.lobe("reflection", wo).dim_u == 2
    assert np.allclose(b.lobe_probabilities(wo[:, 0]).sum(-1), 1)
    with pytest.raises(ValueError, match="lobe"):
        b.lobe("diffuse", wo)


def test_rough_bsdf_parameters_are_checked(raises_naming):
    from vrlab.render.bsdfs.roughdielectric import RoughDielectric
    from vrlab.render.bsdfs.roughplastic import RoughPlastic

    for cls in (RoughPlastic, RoughDielectric):
        with raises_naming(ValueError, "int_ior"):
            cls(int_ior=-1.0)
        with raises_naming(ValueError, "int_ior", "ext_ior"):
            cls(int_ior=1.3, ext_ior=1.3)
        with raises_naming(ValueError, "alpha"):
            cls(alpha=0.0)
        with raises_naming(ValueError, "distribution"):
            cls(distribution="phong")
        with raises_naming(ValueError, "specular_reflectance"):
            cls(specular_reflectance=-1.0)
        with raises_naming(TypeError, "sample_visible"):
            cls(sample_visible="yes")
    with raises_naming(ValueError, "alpha_u"):
        RoughPlastic(alpha_u=0.1, alpha_v=0.2)
    with raises_naming(TypeError, "alpha"):
        RoughPlastic(alpha=Checkerboard(0.1, 0.2))
    with raises_naming(ValueError, "diffuse_reflectance"):
        RoughPlastic(diffuse_reflectance=[0.1, 0.2])
    with raises_naming(TypeError, "nonlinear"):
        RoughPlastic(nonlinear=1)
    with raises_naming(ValueError, "specular_transmittance"):
        RoughDielectric(specular_transmittance=[1.0, float("nan"), 1.0])
    with raises_naming(ValueError, "alpha_u", "alpha_v"):
        RoughDielectric(alpha_u=0.1)


def test_rough_bsdfs_load_from_xml_with_textures():
    from vrlab.render.bsdfs.roughdielectric import RoughDielectric
    from vrlab.render.bsdfs.roughplastic import RoughPlastic

    rp = ('<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="0.2"/>'
          '<string name="int_ior" value="bk7"/><texture type="checkerboard" name="diffuse_reflectance"/>'
          '<boolean name="nonlinear" value="true"/></bsdf>')
    rd = ('<bsdf type="roughdielectric"><float name="alpha_u" value="0.1"/><texture type="checkerboard" '
          'name="alpha_v"><rgb name="color0" value="0.2"/><rgb name="color1" value="0.5"/></texture>'
          '<float name="int_ior" value="1.33"/><boolean name="sample_visible" value="false"/></bsdf>')
    b = load_scene(scene(f'<shape type="sphere">{rp}</shape>')).shapes[-1].bsdf
    assert type(b) is RoughPlastic and b.alpha == 0.2 and b.distribution_type == "ggx" and b.nonlinear
    assert isinstance(b.diffuse_reflectance, Checkerboard) and repr(b).startswith("RoughPlastic(")
    b = load_scene(scene(f'<shape type="sphere">{rd}</shape>')).shapes[-1].bsdf
    assert type(b) is RoughDielectric and b.alpha_u == 0.1 and isinstance(b.alpha_v, Checkerboard)
    assert b.needs_tangents and not b.sample_visible and b.eta == pytest.approx(1.33 / 1.000277)
    at = b.at({"alpha_v": np.array([0.2, 0.5])})
    wo = np.array([direction(0.4), direction(0.4)])
    _, cos_t, _, eta_ti = fresnel_dielectric(wo[:, 2], b.eta)
    wi = refract(wo, cos_t, eta_ti) + np.array([0.0, 0.1, 0.0])       # near the refraction peak
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    e = at.eval(wo, wi)
    assert np.allclose(e[0], RoughDielectric(alpha_u=0.1, alpha_v=0.2, int_ior=1.33, sample_visible=False).eval(wo[0], wi[0]))
    assert e[0, 0] > 0.05 and e[1, 0] > 0.05 and not np.allclose(e[0], e[1])
    with pytest.raises(SceneError, match="alpha_u"):
        load_scene(scene('<shape type="sphere"><bsdf type="roughplastic"><float name="alpha_u" value="0.1"/>'
                         '<float name="alpha_v" value="0.2"/></bsdf></shape>'))


ROUGH_BALL = BALL + '<bsdf type="{type}">{params}</bsdf></shape>'
ROUGH_SCENES = {
    "roughplastic textured beckmann": ROUGH_BALL.format(type="roughplastic", params=(
        '<float name="alpha" value="0.3"/><boolean name="nonlinear" value="true"/><texture type="checkerboard" '
        'name="diffuse_reflectance"><rgb name="color0" value="0.9, 0.5, 0.1"/><transform name="to_uv"><scale '
        'value="4"/></transform></texture>')),
    "rough glass pane from behind, beckmann": PANE.format(
        flip='<boolean name="flip_normals" value="true"/>',
        bsdf='<bsdf type="roughdielectric"><float name="alpha" value="0.3"/><string name="int_ior" value="water"/>'
             '</bsdf>') + EMITTERS["constant"],
    "rough glass ball around a light": BALL + '<bsdf type="roughdielectric"><string name="distribution" value="ggx"/>'
                                              '<float name="alpha" value="0.25"/></bsdf></shape><shape type="sphere">'
                                              '<point name="center" value="-0.3, 0.5, 0"/><float name="radius" '
                                              'value="0.2"/><emitter type="area"><rgb name="radiance" value="4, 2, 1"/>'
                                              '</emitter></shape>',
}


@pytest.mark.parametrize("name", sorted(ROUGH_SCENES))
def test_rough_bsdf_images_agree_with_mitsuba(name):
    """A rough plastic ball (glossy highlights of the area lights over the diffuse base), rough
    glass panes seen from either side with the lights behind them, and a light inside a rough
    glass ball (seen only through the transmission lobe, from inside then outside)."""
    assert_agrees_with_mitsuba(scene(ROUGH_SCENES[name]), estimator="mis-power")


def test_rough_glass_without_radiance_scaling_fails_the_image_criterion(monkeypatch):
    """The light inside the rough glass ball, rendered without the 1 / eta_o^2 of transmitted
    radiance (eval across the surface times eta_o^2), fails against the right scene's reference."""
    from vrlab.render.bsdfs.roughdielectric import RoughDielectric

    xml = scene(ROUGH_SCENES["rough glass ball around a light"])
    spp = max(1, sample_budget() // (W * H))
    reference = (*mitsuba_reference(xml, 4 * spp), 4 * spp)
    assert_agrees_with_mitsuba(xml, estimator="mis-power", reference=reference)
    right = RoughDielectric.eval

    def unscaled(self, wo, wi):
        wo_, wi_ = np.broadcast_arrays(np.asarray(wo), np.asarray(wi))
        eta_o = np.where(wo_[..., 2] > 0, self.eta, 1 / self.eta)
        across = wo_[..., 2] * wi_[..., 2] < 0
        return right(self, wo, wi) * np.where(across, eta_o ** 2, 1.0)[..., None].astype(np.float32)

    monkeypatch.setattr(RoughDielectric, "eval", unscaled)
    with pytest.raises(AssertionError):
        assert_agrees_with_mitsuba(xml, estimator="mis-power", reference=reference)


# ------------------------------------------------------------------ principled, principledthin
def _principled_classes():
    from vrlab.render.bsdfs.principled import Principled
    from vrlab.render.bsdfs.principledthin import PrincipledThin

    return {"principled": Principled, "principledthin": PrincipledThin}


_CHECKER = {"type": "checkerboard", "color0": {"type": "rgb", "value": [0.9, 0.3, 0.1]},
            "color1": {"type": "rgb", "value": [0.1, 0.4, 0.8]}}
PRINCIPLED = {
    "default": {},
    "metal": {"metallic": 1.0, "roughness": 0.3, "base_color": [0.9, 0.6, 0.3]},
    "half metal tinted": {"metallic": 0.5, "base_color": [0.8, 0.3, 0.1], "spec_tint": 0.4, "specular": 0.7},
    "sheen": {"sheen": 0.8, "sheen_tint": 0.5, "base_color": [0.2, 0.7, 0.4], "roughness": 0.7},
    "clearcoat": {"clearcoat": 0.8, "clearcoat_gloss": 0.6, "base_color": [0.1, 0.2, 0.6]},
    "flat": {"flatness": 0.7, "roughness": 0.8},
    "anisotropic": {"anisotropic": 0.7, "roughness": 0.4, "metallic": 0.3},
    "glass": {"spec_trans": 0.7, "roughness": 0.3, "base_color": [0.9, 0.6, 0.3]},
    "glass eta 1.33 clearcoat": {"spec_trans": 0.7, "eta": 1.33, "clearcoat": 0.5, "metallic": 0.2, "sheen": 0.3},
    "rates": {"clearcoat": 0.5, "diffuse_reflectance_sampling_rate": 0.3, "main_specular_sampling_rate": 2.0,
              "clearcoat_sampling_rate": 0.5},
    "textured": {"base_color": "checker", "spec_trans": 0.4, "clearcoat": 0.4},
}
PRINCIPLED_THIN = {
    "default": {},
    "glass": {"spec_trans": 0.8, "roughness": 0.2, "eta": 1.33, "base_color": [0.7, 0.4, 0.2]},
    "everything": {"spec_trans": 0.4, "diff_trans": 0.6, "spec_tint": 0.5, "sheen": 0.5, "sheen_tint": 0.3,
                   "flatness": 0.4, "anisotropic": 0.6, "base_color": [0.3, 0.6, 0.8]},
    "diffuse transmission": {"diff_trans": 1.5, "roughness": 0.9},
    "rates": {"spec_trans": 0.5, "diff_trans": 0.5, "specular_reflectance_sampling_rate": 2.0,
              "specular_transmittance_sampling_rate": 0.5, "diffuse_reflectance_sampling_rate": 0.7,
              "diffuse_transmittance_sampling_rate": 1.5},
    "textured": {"base_color": "checker", "spec_trans": 0.5, "diff_trans": 0.5},
}
PRINCIPLED_CASES = [("principled", k) for k in PRINCIPLED] + [("principledthin", k) for k in PRINCIPLED_THIN]


def principled_pair(family, kw):
    """(vrlab BSDF, Mitsuba BSDF, uv or None) for parameters ``kw`` ("checker": a checkerboard)."""
    theirs = {"type": family}
    ours = {}
    for k, v in kw.items():
        if v == "checker":
            theirs[k] = _CHECKER
            ours[k] = Checkerboard([0.9, 0.3, 0.1], [0.1, 0.4, 0.8])
        else:
            theirs[k] = {"type": "rgb", "value": v} if isinstance(v, list) else v
            ours[k] = v
    bsdf = _principled_classes()[family](**ours)
    return bsdf, mitsuba_bsdf(theirs), "checker" in kw.values()


def _at_uv(bsdf, uv):
    """The BSDF at texture coordinates ``uv`` (its textured parameters looked up there)."""
    from vrlab.render.textures import SurfacePoints

    si = SurfacePoints(uv)
    return bsdf.at({k: (t.eval_1(si) if k in bsdf.SCALAR_TEXTURES else t.eval(si)) for k, t in bsdf.textures.items()})


def _mitsuba_sample_uniforms(bsdf, wo, u):
    """Mitsuba's (sample1, sample2) for vrlab's uniforms: principled takes three (u[2] picks the
    lobe after the normal), principledthin two (a lobe mixture, as the smooth BSDFs)."""
    if bsdf.dim_u == 3:
        return u[:, 2], u[:, :2]
    return mitsuba_uniforms(bsdf, wo, u)


def principled_differences(ours, theirs, textured, seed=0, n=N):
    """Largest relative differences from Mitsuba (values above 1e-4; below, 1e-8 absolute):
    eval and ``pdf_mitsuba`` on pairs over the whole sphere, and samples with the same uniforms
    (wi; weight and pdf of the samples Mitsuba keeps, with |wi_z| >= 0.05)."""
    wo, wi = directions(n, seed + 1, False), directions(n, seed + 2, False)
    uv = np.random.default_rng(seed + 4).random((n, 2)) if textured else None
    b = _at_uv(ours, uv) if textured else ours
    ev, p = bsdf_eval_pdf(theirs, wo, wi, uv=uv)
    u = np.random.default_rng(seed + 3).random((n, b.dim_u))
    r = bsdf_sample(theirs, wo, *_mitsuba_sample_uniforms(b, wo, u), uv=uv)
    s_wi, s_w, s_p = b.sample(wo, u)
    kept = (r.pdf > 0) & (np.abs(r.weight).max(-1) > 0) & (np.abs(r.wi[:, 2]) >= 0.05)
    mp = b.pdf_mitsuba(wo, r.wi)                  # at Mitsuba's direction: sharp lobes amplify float32's
    w_m = b.eval(wo, r.wi) / np.where(mp > 0, mp, 1.0)[:, None]
    # float32 loses digits where a refraction grazes its microfacet (|wi.h| < 0.05: within about 3
    # degrees of the critical angle, relative errors up to 2.5e-4): those pairs are held to 1e-3
    eta = getattr(b, "eta", 1.0) if np.ndim(getattr(b, "eta", 1.0)) == 0 else 1.0
    eta_p = np.where(wo[:, 2] > 0, eta, 1 / eta)[:, None]
    h = wo + eta_p * wi
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    graze = (wo[:, 2] * wi[:, 2] < 0) & (np.abs(np.sum(wi * h, -1)) < 0.05) & isinstance(eta, float)
    e, q = b.eval(wo, wi), b.pdf_mitsuba(wo, wi)
    return {"eval": max_rel(e[~graze], ev[~graze], 1e-4), "pdf": max_rel(q[~graze], p[~graze], 1e-4),
            "grazing": max(max_rel(e[graze], ev[graze], 1e-4) / 10, max_rel(q[graze], p[graze], 1e-4) / 10),
            "wi": float(np.max(np.abs(s_wi - r.wi)[r.pdf > 0])) if np.any(r.pdf > 0) else 0.0,
            "weight": max_rel(w_m[kept], r.weight[kept], 1e-4), "sample pdf": max_rel(mp[kept], r.pdf[kept], 1e-4),
            "kept": int(kept.sum()), "nonzero": int(np.sum(ev.sum(-1) > 0)),
            "self": max_rel(s_w * s_p[:, None], b.eval(wo, s_wi), 1e-4)}


@pytest.mark.parametrize("family, name", PRINCIPLED_CASES)
def test_principled_values_and_samples_equal_mitsubas(family, name):
    """eval and Mitsuba's pdf to 1e-4 on pairs over the whole sphere (both sides; Mitsuba works in
    float32); the same uniforms give the same direction, and Mitsuba's weight is eval /
    ``pdf_mitsuba`` on the samples it keeps; vrlab's own weight is eval / ``pdf``."""
    grid = PRINCIPLED if family == "principled" else PRINCIPLED_THIN
    ours, theirs, textured = principled_pair(family, grid[name])
    d = principled_differences(ours, theirs, textured)
    assert d["eval"] < 1e-4 and d["pdf"] < 1e-4 and d["grazing"] < 1e-4, d
    assert d["wi"] < 1e-4 and d["weight"] < 1e-4 and d["sample pdf"] < 1e-4, d
    assert d["self"] < 1e-10 and d["nonzero"] > N // 8 and d["kept"] > N // 8, d      # comparing something


def test_principled_pdf_counts_what_mitsuba_rejects():
    """``pdf`` (the density of the samples) >= ``pdf_mitsuba`` where wo is seen from outside
    (Mitsuba drops reflections past the horizon and refractions that stay on wo's side), and
    inside without transmission (bsdf = 0) vrlab samples nothing (pdf 0) while Mitsuba reports
    the reflection density; both integrate as they should (tests/test_bsdfs.py-style quadrature)."""
    from vrlab.testing import SphereChart, integrate

    P = _principled_classes()["principled"]
    wo, wi = directions(N, 31, False), directions(N, 32, False)
    for b in (P(spec_trans=0.7, roughness=0.6), P(clearcoat=1.0, roughness=0.8),
              _principled_classes()["principledthin"](spec_trans=0.6, roughness=0.7)):
        seen = (wo[:, 2] > 0) | b.has["spec_trans"]             # inside an opaque one: see below
        exact, mits = b.pdf(wo[seen], wi[seen]), b.pdf_mitsuba(wo[seen], wi[seen])
        assert np.all(exact >= mits * (1 - 1e-9) - 1e-12)
        assert np.any(exact > mits * 1.01)                       # the leaked directions exist
    opaque = P(roughness=0.5)
    inside = wo[:, 2] < 0
    assert np.all(opaque.pdf(wo[inside], wi[inside]) == 0) and np.any(opaque.pdf_mitsuba(wo[inside], wi[inside]) > 0)
    assert np.all(opaque.eval(wo[inside], wi[inside]) == 0)
    w = direction(1.2)
    assert integrate(lambda x: P(spec_trans=0.7, roughness=0.6, clearcoat=0.5).pdf(w, x), SphereChart(2.0), 160) == \
        pytest.approx(1.0, abs=3e-3)


class _PrincipledMutant:
    """Mutations that must fail the value comparison."""

    @staticmethod
    def make(kind):
        P = _principled_classes()["principled"]

        class Mutant(P):
            pass

        if kind == "clearcoat weight 1":
            Mutant.CLEARCOAT_WEIGHT = 1.0
        elif kind == "specular fresnel 1/eta":
            Mutant._dielectric = lambda self, c: fresnel_dielectric(c, 1.0 / self.eta)
        elif kind == "no transmission colour":
            base = P.eval

            def no_colour(self, wo, wi):
                out = base(self, wo, wi)
                refr = (wo[..., 2] * wi[..., 2] < 0)[..., None]
                return np.where(refr, out / np.sqrt(np.asarray(self.base_color)), out)
            Mutant.eval = no_colour
        return Mutant


@pytest.mark.parametrize("kind, kw", [("clearcoat weight 1", {"clearcoat": 0.8}),
                                      ("specular fresnel 1/eta", {"spec_trans": 0.5, "eta": 1.4}),
                                      ("no transmission colour", {"spec_trans": 0.7, "base_color": [0.9, 0.5, 0.2]})])
def test_principled_mutations_fail_the_value_comparison(kind, kw):
    cls = _PrincipledMutant.make(kind)
    theirs = mitsuba_bsdf({"type": "principled", **{k: {"type": "rgb", "value": v} if isinstance(v, list) else v
                                                    for k, v in kw.items()}})
    d = principled_differences(cls(**kw), theirs, False, n=200)
    assert max(d["eval"], d["pdf"], d["weight"]) > 1e-2, d
    good = principled_differences(_principled_classes()["principled"](**kw), theirs, False, n=200)
    assert good["eval"] < 1e-4, good


def test_principled_thin_wrong_roughness_scaling_fails():
    T = _principled_classes()["principledthin"]

    class Unscaled(T):
        def _scaled_roughness(self):
            return self.v("roughness")

    theirs = mitsuba_bsdf({"type": "principledthin", "spec_trans": 0.8, "eta": 1.8})
    assert principled_differences(Unscaled(spec_trans=0.8, eta=1.8), theirs, False, n=200)["eval"] > 1e-2


def _chi_cases():
    P, T = _principled_classes()["principled"], _principled_classes()["principledthin"]
    return {"principled glass": P(spec_trans=0.7, roughness=0.4, clearcoat=0.6, base_color=[0.8, 0.5, 0.3]),
            "principled metal aniso": P(metallic=0.6, anisotropic=0.8, roughness=0.5, sheen=0.5),
            "principledthin": T(spec_trans=0.6, diff_trans=0.8, roughness=0.35, anisotropic=0.5, eta=1.4)}


CHI_CASES = [(name, theta) for name in ("principled glass", "principled metal aniso", "principledthin")
             for theta in (0.3, 1.3, np.pi - 0.9) if not (name == "principled metal aniso" and theta > 2)]


@pytest.mark.parametrize("name, theta", CHI_CASES)
def test_principled_sampler_matches_its_pdf(name, theta):
    """Chi-square on the whole sphere (wo also from below: theta > pi / 2), the chart's pole at
    -wo as tests/test_bsdfs.py; and the pdf integrates to 1."""
    from test_bsdfs import sphere_chart
    from vrlab.testing import integrate

    b = _chi_cases()[name]
    wo = direction(theta)
    res = chi2_gof(b.distribution(wo), sphere_chart(wo), (48, 48), n=100_000, rng=[41, len(name), int(100 * theta)],
                   name=f"{name} theta={theta:.2f}")
    assert_gof(res, m=len(CHI_CASES))
    assert integrate(lambda w: b.pdf(wo, w), sphere_chart(wo), 160) == pytest.approx(1.0, abs=3e-3)


def test_a_wrong_principled_pdf_fails_the_chi_square_test():
    """The lobe choice evaluated at the wrong normal (F at the reflection half vector also for the
    refraction term) is not the density of the samples."""
    from test_bsdfs import sphere_chart
    from vrlab.testing import sidak_threshold

    P = _principled_classes()["principled"]

    class WrongChoice(P):
        def _probabilities(self, front, F):
            return super()._probabilities(front, np.full(np.shape(F), 0.04))

    b = WrongChoice(spec_trans=0.9, roughness=0.5, eta=1.8)
    wo = direction(1.1)
    dist = b.distribution(wo)
    dist.pdf = lambda w: b.pdf(wo, w)
    sampler = _principled_classes()["principled"](spec_trans=0.9, roughness=0.5, eta=1.8)
    dist.sample = lambda u: sampler.distribution(wo).sample(u)
    bad = chi2_gof(dist, sphere_chart(wo), (48, 48), n=100_000, rng=43)
    assert bad.pvalue < sidak_threshold(0.01, len(CHI_CASES))


def test_principled_lobes_and_parameters(raises_naming):
    P, T = _principled_classes()["principled"], _principled_classes()["principledthin"]
    b = P(spec_trans=0.5, clearcoat=0.5)
    assert b.LOBES == ("diffuse", "clearcoat", "specular_transmission", "specular_reflection") and b.dim_u == 3
    wo = directions(50, 51)
    u = np.random.default_rng(52).random((50, 3))
    wi, k = b.sample_lobe(wo, u)
    theirs = mitsuba_bsdf({"type": "principled", "spec_trans": 0.5, "clearcoat": 0.5})
    r = bsdf_sample(theirs, wo, u[:, 2], u[:, :2])
    assert np.all(k[r.pdf > 0] == r.sampled_component[r.pdf > 0])        # Mitsuba's component indices
    for name in b.LOBES:                                                  # each lobe: a distribution of its own
        lobe = b.lobe(name, wo[0])
        x = lobe.sample(np.random.default_rng(53).random((2000, 2)))
        assert np.all(np.asarray(lobe.pdf(x)) > 0)
    m = np.array([0.0, 0.0, 1.0])
    assert np.allclose(b.lobe_probabilities(wo, m).sum(-1), 1.0)
    with raises_naming(ValueError, "m"):
        b.lobe_probabilities(wo)
    assert T().lobe_probabilities(wo).shape == (50, 4)
    assert not P().needs_tangents and P(anisotropic=0.3).needs_tangents
    assert P(specular=0.5).eta == pytest.approx(1.5) and P(spec_trans=0.5, eta=1.0).eta == 1.001
    with raises_naming(ValueError, "eta"):
        P(eta=1.5, specular=0.5)
    for name in ("roughness", "metallic", "clearcoat_gloss", "sheen"):
        with raises_naming(ValueError, name):
            P(**{name: 1.5})
    with raises_naming(ValueError, "diff_trans"):
        T(diff_trans=2.5)
    with raises_naming(ValueError, "base_color"):
        T(base_color=[0.5, 0.5])
    with raises_naming(ValueError, "main_specular_sampling_rate"):
        P(main_specular_sampling_rate=0.0)
    assert repr(P(metallic=0.3)).startswith("Principled(") and "metallic=0.3" in repr(P(metallic=0.3))


def test_principled_loads_from_xml():
    xml = ('<shape type="sphere"><bsdf type="principled"><rgb name="base_color" value="0.8, 0.2, 0.1"/>'
           '<float name="metallic" value="0.4"/><texture type="checkerboard" name="roughness"/>'
           '<float name="eta" value="1.6"/><float name="spec_trans" value="0.3"/></bsdf></shape>')
    b = load_scene(scene(xml)).shapes[-1].bsdf
    assert type(b).__name__ == "Principled" and b.eta == 1.6 and isinstance(b.roughness, Checkerboard)
    t = load_scene(scene('<shape type="sphere"><bsdf type="principledthin"><float name="diff_trans" value="1.2"/>'
                         '</bsdf></shape>')).shapes[-1].bsdf
    assert type(t).__name__ == "PrincipledThin" and t.diff_trans == 1.2
    with pytest.raises(SceneError, match="alpha"):
        load_scene(scene('<shape type="sphere"><bsdf type="principled"><float name="alpha" value="0.1"/></bsdf>'
                         '</shape>'))


PRINCIPLED_SCENES = {
    "principled ball": BALL + '<bsdf type="principled"><rgb name="base_color" value="0.8, 0.3, 0.1"/>'
                              '<float name="metallic" value="0.3"/><float name="roughness" value="0.4"/>'
                              '<float name="clearcoat" value="0.6"/><float name="sheen" value="0.5"/>'
                              '<float name="anisotropic" value="0.5"/></bsdf></shape>' + EMITTERS["point"],
    "principled glass ball": BALL + '<bsdf type="principled"><float name="spec_trans" value="0.8"/>'
                                    '<float name="roughness" value="0.3"/><rgb name="base_color" value="0.9, 0.7, 0.4"/>'
                                    '</bsdf></shape>' + EMITTERS["constant"],
    "principledthin pane": PANE.format(flip="", bsdf='<bsdf type="principledthin"><float name="spec_trans" '
                                                     'value="0.6"/><float name="diff_trans" value="0.8"/><float '
                                                     'name="roughness" value="0.3"/><rgb name="base_color" '
                                                     'value="0.9, 0.6, 0.3"/></bsdf>') + EMITTERS["constant"],
}


@pytest.mark.parametrize("name", sorted(PRINCIPLED_SCENES))
def test_principled_images_agree_with_mitsuba(name):
    assert_agrees_with_mitsuba(scene(PRINCIPLED_SCENES[name]), estimator="mis-power")


def test_adapters_around_bsdfs_that_pick_lobes_after_the_normal():
    """A normal map around principled or roughdielectric turns their own sampler; a blend or a
    mask cannot mix principled's lobes (their probabilities follow the microfacet normal) and
    says so, naming the argument."""
    from vrlab.render.bsdfs.blendbsdf import BlendBSDF
    from vrlab.render.bsdfs.diffuse import Diffuse
    from vrlab.render.bsdfs.mask import Mask
    from vrlab.render.bsdfs.normalmap import NormalMap
    from vrlab.render.bsdfs.principled import Principled
    from vrlab.render.bsdfs.roughdielectric import RoughDielectric

    wo = directions(50, 51)
    for inner in (Principled(), RoughDielectric()):
        nm = NormalMap(inner, [0.6, 0.45, 0.85])
        wi, weight, pdf = nm.sample(wo, np.random.default_rng(52).random((50, 3)))
        ok = pdf > 0
        assert ok.any() and np.allclose(weight[ok] * pdf[ok, None], nm.eval(wo, wi)[ok], rtol=1e-5, atol=1e-7)
    with pytest.raises(ValueError, match="bsdf1"):
        BlendBSDF(Diffuse(), Principled(), 0.5)
    with pytest.raises(ValueError, match="bsdf"):
        Mask(Principled())


# ------------------------------------------------------------------ Mitsuba's BSDF spheres, lit directly
def bsdf_spheres(tmp_path, lights: str, width: int = 48, height: int = 48) -> str:
    """The layout of Mitsuba's ``tests/scenes/bsdf_spheres`` regression scene (its BSDF grid:
    diffuse, textured diffuse, diamond, shiny plastic, rough glass (Beckmann and GGX), rough
    plastics, a conductor and a rough conductor given by eta and k, a masked twosided leaf and
    a masked one-sided leaf) with analytic spheres, generated textures and a ``direct``
    integrator."""
    from PIL import Image

    g = np.random.default_rng(7)
    Image.fromarray((g.random((16, 16, 3)) * 255).astype(np.uint8)).save(tmp_path / "wood.png")
    yy, xx = np.mgrid[0:32, 0:32]
    leaf = (((xx - 15.5) / 14) ** 2 + ((yy - 15.5) / 9) ** 2 < 1).astype(np.uint8) * 255
    Image.fromarray(leaf).save(tmp_path / "leaf.png")
    spheres = {
        (-6, 0): '<bsdf type="diffuse"><rgb name="reflectance" value="0.2 0.5 0.3"/></bsdf>',
        (-3, 0): f'<bsdf type="diffuse"><texture name="reflectance" type="bitmap"><string name="filename" '
                 f'value="{tmp_path / "wood.png"}"/></texture></bsdf>',
        (0, 0): '<bsdf type="dielectric"><string name="int_ior" value="diamond"/><string name="ext_ior" value="air"/>'
                '</bsdf>',
        (3, 0): '<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.1, 0.27, 0.36"/>'
                '<float name="int_ior" value="1.9"/></bsdf>',
        (6, 0): '<bsdf type="roughdielectric"><string name="distribution" value="beckmann"/><float name="alpha" '
                'value="0.02"/><string name="int_ior" value="bk7"/><string name="ext_ior" value="air"/></bsdf>',
        (6, 3): '<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" '
                'value="0.1"/><string name="int_ior" value="bk7"/><string name="ext_ior" value="air"/></bsdf>',
        (3, 3): '<bsdf type="roughplastic"><string name="distribution" value="beckmann"/><float name="alpha" '
                'value="0.1"/><spectrum name="diffuse_reflectance" value="0"/></bsdf>',
        (0, 3): '<bsdf type="roughplastic"><string name="distribution" value="beckmann"/><float name="alpha" '
                'value="0.05"/><spectrum name="diffuse_reflectance" value="0.5"/></bsdf>',
        (-3, 3): '<bsdf type="conductor"><spectrum name="eta" value="0.789000"/><spectrum name="k" value="6.150000"/>'
                 '</bsdf>',
        (-6, 3): '<bsdf type="roughconductor"><string name="distribution" value="beckmann"/><float name="alpha" '
                 'value="0.05"/><spectrum name="eta" value="0.789000"/><spectrum name="k" value="6.150000"/></bsdf>',
    }
    body = "".join(f'<shape type="sphere"><point name="center" value="0, {y}, {z}"/><float name="radius" value="1"/>'
                   f'{b}</shape>' for (y, z), b in spheres.items())
    mask = (f'<bsdf type="mask"><texture name="opacity" type="bitmap"><string name="filename" '
            f'value="{tmp_path / "leaf.png"}"/></texture>{{}}</bsdf>')
    leaf_bsdf = '<bsdf type="diffuse"><rgb name="reflectance" value="0.1 0.8 0.1"/></bsdf>'
    twosided = '<bsdf type="twosided">' + leaf_bsdf + '</bsdf>'
    body += (f'<shape type="rectangle">{mask.format(twosided)}'
             '<transform name="to_world"><rotate z="1" angle="-90"/><rotate y="1" angle="90"/>'
             '<translate x="0.0" y="-6.0" z="-3.0"/></transform></shape>'
             f'<shape type="rectangle">{mask.format(leaf_bsdf)}<transform name="to_world"><rotate z="1" angle="-90"/>'
             '<rotate y="1" angle="-90"/><rotate x="1" angle="180"/><translate x="0.0" y="-3.0" z="-3.0"/>'
             '</transform></shape>')
    return ('<scene version="3.0.0"><integrator type="direct"/><sensor type="perspective"><float name="near_clip" '
            'value="1"/><transform name="to_world"><lookat target="0, 0, 0" origin="-24, 0, 0" up="0, 0, 1"/>'
            f'</transform><film type="hdrfilm"><rfilter type="box"/><integer name="width" value="{width}"/>'
            f'<integer name="height" value="{height}"/></film></sensor>{lights}{body}</scene>')


BSDF_SPHERES_LIGHTS = {
    "constant": '<emitter type="constant"><rgb name="radiance" value="1"/></emitter>',
    "point": '<emitter type="point"><point name="position" value="-20, -8, 10"/><rgb name="intensity" value="900"/>'
             '</emitter>',
    "area": '<shape type="rectangle"><transform name="to_world"><scale value="6"/><rotate y="1" angle="90"/>'
            '<translate x="-30" z="6"/></transform><emitter type="area"><rgb name="radiance" value="3"/></emitter>'
            '</shape>',
}


def test_mitsubas_bsdf_spheres_lit_directly_agree(tmp_path):
    """The grid under a sky, a point light and an area light at once."""
    assert_agrees_with_mitsuba(bsdf_spheres(tmp_path, "".join(BSDF_SPHERES_LIGHTS.values())))


def test_mitsubas_textured_principled_sphere_agrees(tmp_path):
    """Mitsuba's ``test_texturedprincipled1`` regression scene (checkerboard-textured anisotropy,
    metallic, clearcoat and sheen) in its ``single_sphere`` setting (``path`` of depth 2, an
    emissive rectangle with a BSDF, an environment map and a point light), with an analytic
    sphere and this suite's small environment map."""
    env = _envmap_file(tmp_path)
    checker = ('<texture name="{}" type="checkerboard"><transform name="to_uv"><scale x="{s}" y="{s}"/></transform>'
               '<float name="color0" value="{a}"/><float name="color1" value="{b}"/></texture>')
    bsdf = ('<bsdf type="principled"><rgb name="base_color" value="0.2,0.8,0.1"/><float name="roughness" value="0.15"/>'
            + checker.format("anisotropic", s=25, a=0.05, b=0.8) + checker.format("metallic", s=25, a=0.7, b=0.1)
            + checker.format("clearcoat", s=12.5, a=0.9, b=0.1) + checker.format("sheen", s=12.5, a=0.2, b=0.9)
            + '<float name="specular" value="0.7"/></bsdf>')
    xml = ('<scene version="2.0.0"><integrator type="moment"><integrator type="path"><integer name="max_depth" '
           'value="2"/></integrator></integrator><sensor type="perspective"><float name="near_clip" value="1"/>'
           '<transform name="to_world"><lookat target="0, 0, 0" origin="-4, 0, 0" up="0, 0, 1"/></transform>'
           '<film type="hdrfilm"><rfilter type="box"/><integer name="width" value="32"/><integer name="height" '
           f'value="32"/></film></sensor><shape type="sphere">{bsdf}</shape>'
           '<shape type="rectangle"><transform name="to_world"><rotate y="1" angle="120"/><scale value="2"/>'
           '<translate x="-4" z="6"/></transform><bsdf type="diffuse"><spectrum name="reflectance" '
           'value="400:0.78, 500:0.78, 600:0.78, 700:0.78"/></bsdf><emitter type="area"><spectrum name="radiance" '
           'value="400:0, 500:8, 600:15.6, 700:18.4"/></emitter></shape>'
           f'<emitter type="envmap"><string name="filename" value="{env}"/></emitter>'
           '<emitter type="point"><point name="position" x="-4" y="0" z="-6"/><spectrum name="intensity" '
           'value="300"/></emitter></scene>')
    assert_agrees_with_mitsuba(xml)
