"""BSDFs: the common checks (``vrlab.testing.check_bsdf``: chi-square, pdf mass, weight = eval / pdf,
reciprocity, energy) on the reflecting configurations below, transmitting samplers from both sides
(chi-square, pdfs integrate to 1), one-sidedness, closed forms, batching, and unbiased BSDF sampling
through the estimator layer.  Every registered BSDF with its defaults, and every wrapper, are in
tests/test_element_checks.py."""
import numpy as np
import pytest
from scipy import integrate as sint
from scipy import special

from vrlab import Integrand
from vrlab.distributions import to_local, to_world
from vrlab.estimators import MonteCarlo
from vrlab.distributions import Beckmann
from vrlab.render.bsdfs import Diffuse, Phong, RoughConductor, mirror, reflect
from vrlab.render.bsdfs.blendbsdf import BlendBSDF
from vrlab.render.bsdfs.normalmap import NormalMap
from vrlab.render.bsdfs.roughdielectric import RoughDielectric
from vrlab.render.bsdfs.roughplastic import RoughPlastic
from vrlab.render.bsdfs.fresnel import fresnel_dielectric, refract
from vrlab.testing import (
    HemisphereChart,
    SphereChart,
    assert_gof,
    chi2_gof,
    check_bsdf,
    integrate,
    sidak_threshold,
)


class RotatedChart:
    """A cap chart whose pole (+z) is turned to ``axis``: a pole at -wo resolves the
    integrable 1/|wi + wo| peak of the microfacet reflection density there."""

    def __init__(self, chart, axis):
        self.chart, self.axis = chart, np.asarray(axis, float)
        self.p, self.dim_x = chart.p, chart.dim_x

    def to_param(self, x):
        return self.chart.to_param(to_local(np.asarray(x, float), self.axis))

    def from_param(self, s):
        return to_world(self.chart.from_param(s), self.axis)

    def jacobian(self, s):
        return self.chart.jacobian(s)


def direction(theta, phi=0.3):
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


BSDFS = {
    "diffuse": Diffuse([0.2, 0.5, 0.8]),
    "ggx": RoughConductor(0.3, "ggx"),
    "ggx-rough": RoughConductor(0.8, "ggx"),
    "beckmann": RoughConductor(0.3, "beckmann"),
    "ggx-full-ndf": RoughConductor(0.3, "ggx", sample_visible=False),
    "beckmann-full-ndf": RoughConductor(0.3, "beckmann", sample_visible=False),
    "ggx-aniso": RoughConductor(distribution="ggx", alpha_u=0.1, alpha_v=0.45),
    "beckmann-aniso": RoughConductor(distribution="beckmann", alpha_u=0.5, alpha_v=0.15, material="Au"),
    "blend": BlendBSDF(Diffuse(0.4), RoughConductor(0.2, "ggx"), 0.6),
    "normalmap": NormalMap(RoughConductor(0.3, "ggx"), [0.6, 0.45, 0.85]),
    "phong": Phong(0.3, 0.6, 12),
    "phong-spec": Phong(0.0, 0.9, 40),
    "roughplastic": RoughPlastic(0.2, "ggx", diffuse_reflectance=[0.2, 0.5, 0.8]),
    "roughplastic-beckmann-full-ndf": RoughPlastic(0.4, "beckmann", int_ior=1.9, sample_visible=False),
}
#: BSDFs whose samples cover the whole sphere on both sides (wo.z < 0 too: the inside of glass)
TRANSMITTING = {
    "roughdielectric": RoughDielectric(0.3, "ggx"),
    "roughdielectric-beckmann": RoughDielectric(0.3, "beckmann"),
    "roughdielectric-ggx-full-ndf": RoughDielectric(0.3, "ggx", sample_visible=False),
    "roughdielectric-aniso-water": RoughDielectric(distribution="beckmann", alpha_u=0.2, alpha_v=0.5, int_ior="water"),
    "roughdielectric-aniso-full-ndf": RoughDielectric(distribution="beckmann", alpha_u=0.5, alpha_v=0.2,
                                                      sample_visible=False),
    "roughdielectric-smooth-eta<1": RoughDielectric(0.1, "ggx", int_ior=1.0, ext_ior=1.4),
}
THETAS = [0.0, 0.8, 1.45]  # normal, oblique, grazing
INSIDE = [np.pi - 0.5, np.pi - 1.2]  # from inside: below and beyond the critical angle of glass
GOF_CASES = [(k, t) for k in TRANSMITTING for t in THETAS + INSIDE]
ALL = {**BSDFS, **TRANSMITTING}


def sphere_chart(wo):
    return RotatedChart(SphereChart(power=2.0), -wo)


def chart_for(name, wo):
    """The chart of a BSDF's density: a cap at -wo (it resolves the integrable 1 / |wi + wo| peak
    of microfacet reflection sampled by the full NDF), or for a rough dielectric sampled by visible
    normals (whose reflection density has no such peak) a cap at the refraction direction, where
    its transmission peaks (at -wo beyond the critical angle)."""
    b = ALL[name]
    if name not in TRANSMITTING or not b.sample_visible:
        return sphere_chart(wo)
    _, cos_t, _, eta_ti = fresnel_dielectric(wo[2], b.eta)
    return RotatedChart(SphereChart(power=2.0), refract(wo, cos_t, eta_ti) if cos_t != 0 else -wo)


@pytest.mark.parametrize("name", list(BSDFS))
def test_reflecting_configurations_pass_the_common_checks(name):
    """chi2 and mass at three incident directions, weight = eval / pdf, reciprocity (a normal map
    declares itself non-reciprocal), energy (the albedo <= 1): what hand-kept tests did here."""
    out = check_bsdf(BSDFS[name], samples=40_000)
    assert out["chi2"] == out["mass"] == out["weight"] == out["energy"] == "ok"
    assert out["reciprocity"] == ("skipped: the model declares reciprocal = False" if name == "normalmap" else "ok")


@pytest.mark.parametrize("name, theta", GOF_CASES)
def test_sampler_matches_pdf_on_the_sphere(name, theta):
    wo = direction(theta)
    # a rough dielectric's transmission density rises steeply from 0 at the edge of what the
    # facets can refract to (1 - F and |wi.m| -> 0 there): 3 x 3 finer quadrature per cell
    res = chi2_gof(ALL[name].distribution(wo), chart_for(name, wo), (48, 48), n=100_000,
                   rng=[11, len(name), int(100 * theta)], name=f"{name} theta={theta}",
                   sub=3 if name in TRANSMITTING else 1)
    assert_gof(res, m=len(GOF_CASES))


@pytest.mark.parametrize("name, theta", GOF_CASES)
def test_pdf_integrates_to_one_on_the_sphere(name, theta):
    wo = direction(theta)
    bsdf = ALL[name]
    assert integrate(lambda w: bsdf.pdf(wo, w), chart_for(name, wo), 128) == pytest.approx(1.0, abs=2e-3)


LOBE_CASES = [(k, lobe, t) for k in ("roughdielectric", "roughdielectric-ggx-full-ndf")
              for lobe in ("reflection", "transmission") for t in (0.8, np.pi - 1.2)]


@pytest.mark.parametrize("name, lobe, theta", LOBE_CASES)
def test_roughdielectric_lobes_match_their_pdfs(name, lobe, theta):
    """Each lobe alone (for MIS over lobes): reflection, and transmission, which reflects where
    the microfacet totally reflects (theta = pi - 1.2 is beyond glass's critical angle)."""
    wo = direction(theta)
    dist = TRANSMITTING[name].lobe(lobe, wo)
    res = chi2_gof(dist, chart_for(name, wo), (48, 48), n=100_000, rng=[12, len(name), len(lobe), int(100 * theta)],
                   sub=3)
    assert_gof(res, m=len(LOBE_CASES))
    assert integrate(dist.pdf, chart_for(name, wo), 128) == pytest.approx(1.0, abs=2e-3)


class _DroppedJacobian(RoughDielectric):
    """A rough dielectric whose transmission density forgets the factor e^2 of the refraction
    Jacobian (a mutation that must fail)."""

    def branch_terms(self, wo, wi, mode="mixture"):
        p_r, p_same, p_other = super().branch_terms(wo, wi, mode)
        e2 = np.where(np.asarray(wo)[..., 2] > 0, self.eta, 1 / self.eta) ** 2
        return p_r, p_same / e2, p_other * e2


@pytest.mark.parametrize("theta", [0.8, np.pi - 0.5])
def test_a_dropped_refraction_jacobian_fails_the_chi_square_test(theta):
    wo = direction(theta)
    b = _DroppedJacobian(0.3, "ggx")
    bad = chi2_gof(b.distribution(wo), sphere_chart(wo), (48, 48), n=100_000, rng=[13, int(100 * theta)], sub=3)
    with pytest.raises(AssertionError):
        assert_gof(bad, m=len(GOF_CASES))
    assert abs(integrate(lambda w: b.pdf(wo, w), sphere_chart(wo), 128) - 1.0) > 0.05


@pytest.mark.parametrize("name", list(TRANSMITTING))
def test_transmitting_sample_weights_and_batches(name):
    """Three uniforms per sample; weight = eval / pdf on both sides; batched equals one at a time."""
    b = TRANSMITTING[name]
    rng = np.random.default_rng(3)
    wo = rng.normal(size=(4, 5, 3))
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    u = rng.random((4, 5, 7, 3))
    wi, weight, pdf = b.sample(wo[..., None, :], u)
    assert wi.shape == (4, 5, 7, 3) and weight.shape == (4, 5, 7, 3) and pdf.shape == (4, 5, 7)
    np.testing.assert_allclose(np.linalg.norm(wi, axis=-1), 1.0)
    assert np.all(pdf > 0)
    np.testing.assert_allclose(weight, b.eval(wo[..., None, :], wi) / pdf[..., None], rtol=1e-10)
    np.testing.assert_allclose(pdf, b.pdf(wo[..., None, :], wi), rtol=1e-12)
    one = b.sample(wo[1, 2], u[1, 2])
    for got, want in zip((wi[1, 2], weight[1, 2], pdf[1, 2]), one):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
    assert np.any(wi[..., 2] * wo[..., None, 2] < 0) and np.any(wi[..., 2] * wo[..., None, 2] > 0)
    with pytest.raises(ValueError, match="u"):
        b.sample(wo, rng.random((4, 5, 2)))


def test_microfacet_upper_hemisphere_mass_is_below_one_at_grazing():
    # what is true: the whole-sphere density integrates to 1; restricted to wi.z > 0 (Mitsuba's
    # pdf) it integrates to P(wo·m > 0 and reflect(wo, m).z > 0): 1 at normal incidence, < 1 grazing
    b = RoughConductor(0.5, "ggx", sample_visible=False)
    up = lambda wo, b=b: integrate(lambda w: b.pdf(wo, w) * (w[..., 2] > 0), HemisphereChart(2), 128)
    # at wo = n, m beyond 45 deg reflects below: P(tan^2 theta_m < 1) = 1 / (1 + alpha^2) for GGX
    assert up(direction(0.0)) == pytest.approx(1 / (1 + 0.25), abs=2e-3)
    wo = direction(1.45)
    u = np.random.default_rng(0).random((200_000, 2))
    frac = np.mean(b.distribution(wo).sample(u)[..., 2] > 0)
    assert up(wo) < 0.9
    assert up(wo) == pytest.approx(frac, abs=4 * np.sqrt(frac * (1 - frac) / len(u)) + 2e-3)
    # visible normals (Mitsuba's default) never face away from wo: fewer samples are wasted
    assert up(wo, RoughConductor(0.5, "ggx")) > up(wo) + 0.03


def albedo(bsdf, wo, channel=0):
    """Quadrature of int f cos d(omega_i) over the upper hemisphere."""
    return integrate(lambda w: bsdf.eval(wo, w)[..., channel], HemisphereChart(2), 160)


def microfacet_albedo_normal_incidence(alpha, kind):
    """Independent 1D reference at wo = n: albedo = int_0^{pi/4} D(h) cos G1(wi) 2 pi sin dtheta_h,
    wi at polar angle 2 theta_h (dw_i = 4 cos theta_h dw_h, G1(n) = 1)."""
    def integrand(t):
        tan2 = np.tan(t) ** 2
        c = np.cos(t)
        if kind == "ggx":
            D = alpha**2 / (np.pi * c**4 * (alpha**2 + tan2) ** 2)
            g = 2 / (1 + np.sqrt(1 + alpha**2 * np.tan(2 * t) ** 2))
        else:
            D = np.exp(-tan2 / alpha**2) / (np.pi * alpha**2 * c**4)
            a = 1 / (alpha * abs(np.tan(2 * t))) if t > 0 else np.inf
            g = 1.0 if a >= 1.6 else (3.535 * a + 2.181 * a * a) / (1 + 2.276 * a + 2.577 * a * a)
        return D * c * g * 2 * np.pi * np.sin(t)
    return sint.quad(integrand, 0, np.pi / 4, limit=200, epsabs=1e-12)[0]


def test_diffuse_albedo_is_reflectance():
    b = Diffuse([0.2, 0.5, 0.8])
    for t in THETAS:
        for c, r in enumerate([0.2, 0.5, 0.8]):
            assert albedo(b, direction(t), c) == pytest.approx(r, rel=1e-5)


@pytest.mark.parametrize("kind", ["ggx", "beckmann"])
@pytest.mark.parametrize("alpha", [0.05, 0.3])
def test_microfacet_albedo_matches_independent_quadrature(kind, alpha):
    b = RoughConductor(alpha, kind)
    ref = microfacet_albedo_normal_incidence(alpha, kind)
    assert albedo(b, direction(0.0)) == pytest.approx(ref, rel=2e-3)
    if alpha == 0.05:
        assert 0.99 < ref <= 1.0 + 1e-9  # smooth: almost no shadowing loss


@pytest.mark.parametrize("name", list(BSDFS))
def test_one_sidedness(name):
    rng = np.random.default_rng(5)
    wo, wi = rng.normal(size=(2, 1000, 3))
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    b = BSDFS[name]
    if name == "normalmap":
        pytest.skip("a normal map is neither reciprocal nor one-sided in the true frame (as in Mitsuba: its "
                    "frame and terminator term depend on wo and wi); tests/test_bsdf_families.py compares it")
    below = (wo[:, 2] <= 0) | (wi[:, 2] <= 0)
    assert np.all(b.f(wo, wi)[below] == 0) and np.all(b.eval(wo, wi)[below] == 0)
    assert np.any(b.f(wo, wi)[~below] > 0)
    np.testing.assert_allclose(b.eval(wo, wi), b.f(wo, wi) * np.clip(wi[:, 2:3], 0, None))


def test_closed_form_values():
    n = np.array([0.0, 0.0, 1.0])
    w = direction(0.7)
    np.testing.assert_allclose(Diffuse([0.2, 0.5, 0.8]).f(w, direction(1.1, 2.0)), np.array([0.2, 0.5, 0.8]) / np.pi)
    np.testing.assert_allclose(Diffuse(0.5).sample(w, [[0.3, 0.6]])[1], [[0.5, 0.5, 0.5]])
    for kind in ["ggx", "beckmann"]:  # D(n) = 1 / (pi alpha^2) for both, G1(n) = 1
        for alpha in [0.1, 0.5]:
            b = RoughConductor(alpha, kind)
            np.testing.assert_allclose(b.eval(n, n), np.full(3, 1 / (4 * np.pi * alpha**2)))
            assert b.pdf(n, n) == pytest.approx(1 / (4 * np.pi * alpha**2))
    np.testing.assert_allclose(Phong(0.3, 0.6, 12).f(n, n), np.full(3, 0.3 / np.pi + 0.6 * 14 / (2 * np.pi)))
    np.testing.assert_allclose(Phong(0.3, 0.6, 12).f(w, mirror(w)), Phong(0.3, 0.6, 12).f(n, n))
    np.testing.assert_allclose(reflect(w, n), mirror(w))


def test_smith_g1_sign_checks_and_beckmann_approximation():
    b = RoughConductor(0.4, "beckmann")
    g = RoughConductor(0.4, "ggx")
    v, m = direction(0.6), direction(0.1, 0.3)
    for x in (b, g):
        assert x.G1(v, m) > 0.9
        assert x.G1(v, -m) == 0  # back of the microfacet
        assert x.G1(-v, m) > 0.9  # (v·m) cos(theta_v) > 0: Mitsuba checks only this product
        assert x.G1(direction(1.7), direction(0.5)) == 0  # v below the surface sees the facet's front
        assert x.G1(direction(0.0), direction(0.0)) == 1
    # the rational approximation stays within 0.35% of the exact Beckmann Smith G1 (Walter et al. 2007)
    theta = np.linspace(0.05, 1.55, 300)
    vs = np.stack([np.sin(theta), 0 * theta, np.cos(theta)], -1)
    a = 1 / (0.4 * np.tan(theta))
    lam = (special.erf(a) - 1) / 2 + np.exp(-a * a) / (2 * a * np.sqrt(np.pi))
    np.testing.assert_allclose(b.G1(vs, np.array([0, 0, 1.0])), 1 / (1 + lam), rtol=4e-3)
    # GGX G1 is exact: 1 / (1 + Lambda), Lambda = (-1 + sqrt(1 + alpha^2 tan^2)) / 2
    lam = (-1 + np.sqrt(1 + 0.16 * np.tan(theta) ** 2)) / 2
    np.testing.assert_allclose(g.G1(vs, np.array([0, 0, 1.0])), 1 / (1 + lam), rtol=1e-12)


def test_beckmann_normals_sampler():
    res = chi2_gof(Beckmann(0.3), HemisphereChart(power=2.0), (40, 20), n=100_000, rng=4)
    assert_gof(res)
    assert integrate(Beckmann(0.3).pdf, HemisphereChart(2), 128) == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("name", list(BSDFS))
def test_batched_shapes_and_agreement(name):
    b = BSDFS[name]
    rng = np.random.default_rng(9)
    wo = to_world(np.array([0.3, 0.1, 0.9]) / np.linalg.norm([0.3, 0.1, 0.9]), np.array([0, 0, 1.0]))
    wo = np.broadcast_to(wo, (4, 5, 3)) * 1.0
    wo[1] = direction(1.2)
    wi = rng.normal(size=(4, 5, 3))
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    assert b.eval(wo, wi).shape == (4, 5, 3) and b.f(wo, wi).shape == (4, 5, 3)
    assert b.pdf(wo, wi).shape == (4, 5)
    u = rng.random((4, 5, 7, 2))
    d = b.distribution(wo[..., None, :])
    x = d.sample(u)
    assert x.shape == (4, 5, 7, 3) and d.pdf(x).shape == (4, 5, 7)
    wi_s, weight, pdf = b.sample(wo[..., None, :], u)
    assert wi_s.shape == (4, 5, 7, 3) and weight.shape == (4, 5, 7, 3) and pdf.shape == (4, 5, 7)
    # batched equals one at a time
    one = b.sample(wo[1, 2], u[1, 2])
    for got, want in zip((wi_s[1, 2], weight[1, 2], pdf[1, 2]), one):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(b.eval(wo, wi)[3, 4], b.eval(wo[3, 4], wi[3, 4]))


def test_a_missing_jacobian_fails_the_chi_square_test():
    class NoJacobian(RoughConductor):
        def pdf(self, wo, wi):  # the density of m, not of wi: forgets 1 / (4 |wo·m|)
            h = wo + wi
            h = h / np.linalg.norm(h, axis=-1, keepdims=True)
            return self.normals.pdf(np.where(h[..., 2:3] < 0, -h, h))

    wo = direction(0.8)
    bad = chi2_gof(NoJacobian(0.3).distribution(wo), sphere_chart(wo), (48, 48), n=100_000, rng=1)
    assert bad.pvalue < sidak_threshold(0.01, len(GOF_CASES))
    with pytest.raises(AssertionError):
        assert_gof(bad)


@pytest.mark.parametrize("name", ["diffuse", "ggx", "beckmann", "phong"])
def test_bsdf_sampling_through_the_estimator_is_unbiased(name):
    b = BSDFS[name]
    wo = direction(1.0)
    ref = albedo(b, wo)
    it = Integrand(lambda wi: b.eval(wo, wi)[..., 0], "sphere")
    est = MonteCarlo(b.distribution(wo)).estimate(it, 100_000, rng=[3, len(name)])
    assert abs(est.value - ref) < 4 * est.stderr + 1e-12


def test_bad_arguments():
    with pytest.raises(ValueError, match="distribution"):
        RoughConductor(0.1, "phong")
    with pytest.raises(ValueError, match="alpha"):
        RoughConductor(0.0)
    with pytest.raises(ValueError, match="reflectance"):
        Diffuse([0.1, 0.2])
    with pytest.raises(ValueError, match="exponent"):
        Phong(0.1, 0.1, -1)
    with pytest.raises(ValueError, match="wi"):
        Diffuse(0.5).eval(np.array([0, 0, 1.0]), np.zeros(2))
