"""vrlab.render.bsdfs.fresnel (Fresnel equations, refraction, named IORs and conductors) against
closed forms and against Mitsuba 3.9.1 itself (``mi.fresnel``, ``mi.fresnel_conductor``,
``mi.fresnel_diffuse_reflectance``, ``mi.refract`` and its ``dielectric``/``conductor`` plugins
through vrlab.testing.mitsuba_bsdf), and the probe's own conventions."""
import time

import numpy as np
import pytest

from vrlab.render.bsdfs.base import mirror
from vrlab.render.bsdfs.fresnel import (IOR_TABLE, conductor_ior, fresnel_conductor, fresnel_diffuse_reflectance,
                                        fresnel_dielectric, ior_value, refract, relative_ior)
from vrlab.render.spectra import CONDUCTORS

#: vrlab (float64 or float32) vs Mitsuba (float32): relative, with an absolute floor for tiny F
REL, ABS = 1e-5, 1e-6
ETAS = [0.2, 0.5, 1 / 1.5046, 0.9, 0.999, 1.0, 1.001, 1.333, 1.5, 1.5046, 2.419, 4.0, 10.0]
COS = np.concatenate([np.linspace(-1, 1, 401), [0.0, -0.0, 1e-4, -1e-4, 1e-7, -1e-7, 0.9999, -0.9999]])
COS = COS.astype(np.float32).astype(float)        # inputs both sides represent exactly


@pytest.fixture(scope="module")
def mi():
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    return mi


def excess(ours, theirs, rel=REL, abs_=ABS):
    """max(|ours - theirs| / tolerance): <= 1 means within tolerance."""
    ours, theirs = np.asarray(ours, float), np.asarray(theirs, float)
    return float(np.max(np.abs(ours - theirs) / np.maximum(rel * np.abs(theirs), abs_)))


def mitsuba_fresnel(mi, cos, eta):
    return np.array([mi.fresnel(float(c), float(eta)) for c in cos])


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


# ----------------------------------------------------------------------------- dielectric
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_dielectric_matches_mitsuba(mi, dtype):
    """F, cos theta_t, eta_it, eta_ti on a grid of both signs incl. grazing, +-0 and TIR.  Within
    0.01 of cos^2 theta_t = 0 (the critical angle) Mitsuba's float32 is not good to 1e-5 (d F /
    d cos^2 theta_t is unbounded there; 5e-5 relative at eta = 1.001): those points are checked
    by the closed forms (test_total_internal_reflection) instead."""
    for eta in np.float32(ETAS):
        ours = fresnel_dielectric(COS.astype(dtype), dtype(eta))
        assert all(np.asarray(x).dtype == dtype for x in ours)
        theirs = mitsuba_fresnel(mi, COS, eta)
        cos_t2 = 1 - (1 - COS**2) * np.where(COS >= 0, 1 / float(eta), float(eta))**2
        ok = np.abs(cos_t2) > 1e-2
        assert excess(ours.F[ok], theirs[ok, 0]) <= 1, eta
        tir = cos_t2 < -1e-2
        assert np.all(ours.F[tir] == 1) and np.all(theirs[tir, 0] == 1)
        assert excess(ours.cos_theta_t[ok]**2, theirs[ok, 1]**2) <= 1, eta
        assert np.all(np.signbit(ours.cos_theta_t[ok]) == np.signbit(theirs[ok, 1])), eta
        assert excess(ours.eta_it, theirs[:, 2], 1e-6) <= 1 and excess(ours.eta_ti, theirs[:, 3], 1e-6) <= 1


def test_dielectric_closed_forms():
    for eta in ETAS:
        r0 = ((eta - 1) / (eta + 1))**2
        for c in (1.0, -1.0):
            assert fresnel_dielectric(c, eta).F == pytest.approx(r0, rel=1e-12, abs=1e-300)
        assert fresnel_dielectric(0.0, eta).F == (0.0 if eta == 1 else 1.0)         # grazing
    f = fresnel_dielectric(COS, 1.0)                                              # index matched
    assert np.all(f.F == 0) and np.allclose(f.cos_theta_t, -COS, atol=1e-7)
    for eta in (1.333, 1.5046, 2.419, 0.5):
        f = fresnel_dielectric(COS, eta)
        ci, ct = np.abs(COS), np.abs(f.cos_theta_t)
        refr = (f.F < 1) & (ci > 1e-3)          # (at grazing incidence the cosines lose digits)
        # Snell: sin theta_t = eta_ti sin theta_i; the refracted ray crosses to the other side
        assert np.allclose(np.sqrt(1 - ct[refr]**2), f.eta_ti[refr] * np.sqrt(1 - ci[refr]**2), atol=1e-12)
        assert np.all(np.sign(f.cos_theta_t[refr]) == -np.sign(COS[refr]))
        # energy: R + T = 1 with T from the transmission amplitudes (Born & Wolf 1.5.2)
        n = f.eta_it[refr]
        ci_, ct_ = ci[refr], ct[refr]
        t_s, t_p = 2 * ci_ / (ci_ + n * ct_), 2 * ci_ / (n * ci_ + ct_)
        T = n * ct_ / ci_ * 0.5 * (t_s**2 + t_p**2)
        np.testing.assert_allclose(f.F[refr] + T, 1, rtol=1e-12)
        # reciprocity (Stokes): the same F from the other side along the refracted direction
        back = fresnel_dielectric(f.cos_theta_t[refr], eta)
        np.testing.assert_allclose(back.F, f.F[refr], rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(back.cos_theta_t, COS[refr], atol=1e-9)


def test_total_internal_reflection(mi):
    for eta in (1.000277, 1.333, 1.5046, 2.419):
        crit = np.sqrt(1 - 1 / eta**2)                    # |cos theta_i| of the critical angle, inside
        beyond = -np.linspace(1e-9, crit * (1 - 1e-6), 50)      # (-0.0 is 'outside')
        f = fresnel_dielectric(beyond, eta)
        assert np.all(f.F == 1) and np.all(f.cos_theta_t == 0)
        assert all(mi.fresnel(float(c), eta)[0] == 1 for c in beyond[::7] if abs(c) < crit * 0.999)
        before = -crit * (1 + np.array([1e-2, 1e-4, 1e-6]))
        F = fresnel_dielectric(before, eta).F
        assert np.all(np.diff(F) > 0) and F[-1] > 0.98 and np.all(F < 1)   # continuous up to 1
        # from outside, eta < 1 has the same critical angle
        np.testing.assert_array_equal(fresnel_dielectric(-beyond, 1 / eta).F, 1)


# ----------------------------------------------------------------------------- conductor
PAIRS = [(0.2, 3.0), (0.0, 1.0), (1.5, 0.0), (0.5, 0.0), (2.9, 3.1), (0.143, 3.983), (1.44, 1.60), (1.0, 0.01),
         (10.0, 10.0), (0.06, 3.18)]


def complex_form(c, eta, k):
    """The definition in complex arithmetic (Born & Wolf 1.5.2 with n = eta + i k)."""
    n2 = (eta + 1j * k)**2
    w = np.sqrt(n2 - (1 - c * c) + 0j)
    r_s, r_p = (c - w) / (c + w), (n2 * c - w) / (n2 * c + w)
    return 0.5 * (np.abs(r_s)**2 + np.abs(r_p)**2)


def test_conductor_matches_mitsuba(mi):
    cos = COS[COS >= 0]
    for eta, k in PAIRS:
        ours = fresnel_conductor(cos, eta, k)
        theirs = [mi.fresnel_conductor(float(c), mi.Complex2f(eta, k)) for c in cos]
        assert excess(ours, theirs) <= 1, (eta, k)


def test_conductor_equals_the_complex_form():
    """Exact agreement in float64, also where float32 cancels badly (eta and k both small)."""
    c = np.linspace(1e-6, 1, 2001)
    for eta, k in PAIRS + [(0.05, 0.01), (0.01, 0.05), (3.0, 0.001), (0.3, 0.0)]:
        np.testing.assert_allclose(fresnel_conductor(c, eta, k), complex_form(c, eta, k), rtol=1e-10, atol=1e-15)


def test_conductor_closed_forms():
    c = np.linspace(0, 1, 101)
    for eta, k in PAIRS:
        assert fresnel_conductor(1.0, eta, k) == pytest.approx(((eta - 1)**2 + k**2) / ((eta + 1)**2 + k**2),
                                                                rel=1e-12)
        assert fresnel_conductor(0.0, eta, k) == 1.0
    for eta in (1.5, 2.4, 0.5, 0.9):                   # k = 0: a dielectric seen from outside (TIR for eta < 1)
        np.testing.assert_allclose(fresnel_conductor(c, eta, 0.0), fresnel_dielectric(c, eta).F, rtol=1e-12,
                                   atol=1e-15)
    np.testing.assert_allclose(fresnel_conductor(c, 0.0, 1.0), 1.0, rtol=1e-15)    # "none": a perfect mirror
    assert fresnel_conductor(1.0, 0.0, 0.0) == 1.0 and fresnel_conductor(0.0, 1.0, 0.0) == 0.0   # limits
    np.testing.assert_array_equal(fresnel_conductor(c, 1.0, 0.0), 0.0)    # index matched
    np.testing.assert_array_equal(fresnel_conductor(-c, 0.2, 3.0), fresnel_conductor(c, 0.2, 3.0))
    eta, k = conductor_ior("Au")
    out = fresnel_conductor(c, eta, k)
    assert out.shape == (101, 3) and fresnel_conductor(c, 0.2, 3.0).shape == (101,)
    per_point = fresnel_conductor(c, np.tile(eta, (101, 1)), np.tile(k, (101, 1)))
    np.testing.assert_array_equal(per_point, out)
    for j in range(3):
        np.testing.assert_allclose(out[:, j], fresnel_conductor(c, eta[j], k[j]), rtol=1e-14)


def test_float32_stays_float32():
    c32 = np.linspace(-1, 1, 9, dtype=np.float32)
    assert all(x.dtype == np.float32 for x in fresnel_dielectric(c32, 1.5))
    assert fresnel_conductor(c32, np.float32([0.2, 0.3, 1.1]), np.float32([3, 3, 2])).dtype == np.float32
    assert fresnel_conductor(c32, 0.2, 3.0).dtype == np.float32
    assert fresnel_diffuse_reflectance(np.float32([0.7, 1.5])).dtype == np.float32
    w = unit(np.array([[0.3, 0.2, 0.9]], np.float32))
    f = fresnel_dielectric(w[:, 2], 1.5)
    assert refract(w, f.cos_theta_t, f.eta_ti).dtype == np.float32
    assert fresnel_dielectric([1, 0], 2).F.dtype == np.float64 and fresnel_diffuse_reflectance(2).dtype == np.float64
    np.testing.assert_allclose(fresnel_dielectric(c32, 1.5).F, fresnel_dielectric(c32.astype(float), 1.5).F,
                               rtol=1e-5, atol=1e-7)


# ----------------------------------------------------------------------------- diffuse reflectance
def test_fresnel_diffuse_reflectance_matches_mitsuba(mi):
    eta = np.float32(np.concatenate([np.linspace(0.05, 20, 800), [1.0, 0.99999, 1.00001]])).astype(float)
    theirs = [mi.fresnel_diffuse_reflectance(float(e)) for e in eta]
    assert excess(fresnel_diffuse_reflectance(eta), theirs) <= 1
    assert excess(fresnel_diffuse_reflectance(eta.astype(np.float32)), theirs) <= 1


def _hemispherical_average(eta):
    """2 int_0^1 F(mu, eta) mu dmu by Gauss-Legendre on the part below the critical angle."""
    x, w = np.polynomial.legendre.leggauss(200)
    lo = np.sqrt(max(0.0, 1 - eta * eta)) if eta < 1 else 0.0           # TIR (F = 1) below lo
    mu = lo + (1 - lo) * (x + 1) / 2
    return float(np.sum(w * fresnel_dielectric(mu, eta).F * mu) * (1 - lo) + lo * lo)


def test_fresnel_diffuse_reflectance_approximates_the_hemispherical_average():
    """The accuracy stated in the docstring (fits, not the integral: Mitsuba's choice)."""
    for eta in np.linspace(0.5, 2, 61):
        assert abs(fresnel_diffuse_reflectance(eta) - _hemispherical_average(eta)) < 2e-3, eta
    for eta in np.linspace(1.5, 2, 11):
        assert fresnel_diffuse_reflectance(eta) == pytest.approx(_hemispherical_average(eta), rel=3e-4)
    for eta in np.linspace(2, 10, 33):
        assert fresnel_diffuse_reflectance(eta) == pytest.approx(_hemispherical_average(eta), rel=1.4e-2)


# ----------------------------------------------------------------------------- refraction
def test_refract_matches_mitsuba(mi):
    rng = np.random.default_rng(1)
    w = unit(rng.normal(size=(200, 3)))
    m = unit(rng.normal(size=(200, 3)) * [0.3, 0.3, 1.0])
    m[:, 2] = np.abs(m[:, 2])
    for eta in (1.5046, 1 / 1.333):
        f = fresnel_dielectric(w[:, 2], eta)
        ours = refract(w, f.cos_theta_t, f.eta_ti)
        g = fresnel_dielectric(np.sum(w * m, -1), eta)
        ours_m = refract(w, g.cos_theta_t, g.eta_ti, m)
        for j in range(len(w)):
            v = mi.Vector3f(*w[j])
            if f.F[j] < 1:
                assert excess(ours[j], mi.refract(v, float(f.cos_theta_t[j]), float(f.eta_ti[j])), 1e-6) <= 1
            if g.F[j] < 1:
                theirs = mi.refract(v, mi.Normal3f(*m[j]), float(g.cos_theta_t[j]), float(g.eta_ti[j]))
                assert excess(ours_m[j], theirs, 1e-6) <= 1


def test_refract_obeys_snell():
    rng = np.random.default_rng(2)
    w = unit(rng.normal(size=(500, 3)))
    for eta in (1.5, 0.7):
        f = fresnel_dielectric(w[:, 2], eta)
        t = refract(w, f.cos_theta_t, f.eta_ti)
        ok = f.F < 1
        np.testing.assert_allclose(np.linalg.norm(t[ok], axis=-1), 1, rtol=1e-12)
        np.testing.assert_allclose(t[ok, :2], -f.eta_ti[ok, None] * w[ok, :2], rtol=1e-12)
        assert np.all(t[ok, 2] * w[ok, 2] < 0)
        np.testing.assert_allclose(refract(w, f.cos_theta_t, f.eta_ti, [0, 0, 1]), t, atol=1e-15)


# ----------------------------------------------------------------------------- named IORs
def test_named_iors_through_mitsubas_dielectric(mi):
    """Every name: Mitsuba's stored eta, and its dielectric's lobe probabilities (pdf = F of the
    reflection picked by u1 = 0, 1 - F of a refraction picked by u1 = 1) and refracted ray."""
    from vrlab.testing.mitsuba_bsdf import bsdf_sample, mitsuba_bsdf

    cos = np.array([1.0, 0.7, 0.3, 0.1, -1.0, -0.7, -0.3])
    wo = np.stack([np.sqrt(1 - cos**2), np.zeros_like(cos), cos], -1)
    for name in IOR_TABLE:
        b = mitsuba_bsdf({"type": "dielectric", "int_ior": name, "ext_ior": "vacuum"})
        eta = relative_ior(name, "vacuum")
        assert eta == ior_value(name) and excess(eta, b.parameters()["eta"], 1e-6) <= 1, name
        f = fresnel_dielectric(cos, eta)
        refl = bsdf_sample(b, wo, 0.0, [0.5, 0.5])
        assert excess(refl.pdf, f.F) <= 1, name
        np.testing.assert_allclose(refl.wi, mirror(wo), atol=1e-6)
        refr = bsdf_sample(b, wo, 1.0, [0.5, 0.5])
        t = f.F < 1
        assert excess(refr.pdf[t], 1 - f.F[t]) <= 1, name
        assert excess(refr.wi[t], refract(wo, f.cos_theta_t, f.eta_ti)[t], 1e-5) <= 1, name
        assert excess(refr.eta[t], f.eta_it[t], 1e-6) <= 1
        assert excess(refr.weight[t], np.repeat(f.eta_ti[t, None]**2, 3, 1), 1e-6) <= 1     # radiance mode
    b = mitsuba_bsdf({"type": "dielectric"})                    # Mitsuba's defaults: bk7 in air
    assert excess(relative_ior("bk7", "air"), b.parameters()["eta"], 1e-6) <= 1
    assert excess(relative_ior("polypropylene", "air"),
                  mitsuba_bsdf({"type": "plastic"}).parameters()["eta"], 1e-6) <= 1


def test_ior_values():
    assert ior_value("BK7") == ior_value("bk7") == 1.5046 and ior_value("Acrylic Glass") == 1.49
    assert ior_value(1.7, "int_ior") == 1.7 and ior_value(np.float32(2), "ext_ior") == 2.0
    assert relative_ior("water", 1.0) == 1.333 and relative_ior(1.5, 1.5) == 1.0


# ----------------------------------------------------------------------------- named conductors
def test_named_conductors_through_mitsubas_conductor(mi):
    """Every material: Mitsuba's stored RGB eta, k and its mirror's weight F(cos) at five angles."""
    from vrlab.testing.mitsuba_bsdf import bsdf_sample, flag_names, mitsuba_bsdf

    cos = np.array([1.0, 0.8, 0.5, 0.2, 0.05])
    wo = np.stack([np.sqrt(1 - cos**2) * 0.6, np.sqrt(1 - cos**2) * 0.8, cos], -1)
    for name in CONDUCTORS:
        b = mitsuba_bsdf({"type": "conductor", "material": name})
        eta, k = conductor_ior(name)
        params = b.parameters()
        assert excess(eta, np.broadcast_to(params["eta.value"], 3), 1e-5, 1e-9) <= 1, name
        assert excess(k, np.broadcast_to(params["k.value"], 3), 1e-5, 1e-9) <= 1, name
        s = bsdf_sample(b, wo, 0.5, [0.5, 0.5])
        ours = fresnel_conductor(cos, eta, k)
        nan = np.isnan(s.weight)              # Mitsuba's 0/0 for eta = k = 0 (AlSb's red) at normal incidence
        assert excess(s.weight[~nan], ours[~nan]) <= 1, name
        assert np.all(ours[nan] == 1) and np.all((eta == 0) & (k == 0) | ~nan.any(0)), name
        np.testing.assert_allclose(s.wi, mirror(wo), atol=1e-6)
        assert set(s.sampled_type.tolist()) == {32} and flag_names(32) == ("DeltaReflection",)


# ----------------------------------------------------------------------------- mutations
def test_mutation_inverted_ior_fails_the_comparison(mi):
    cos = COS[COS > 0.05]
    for eta in (1.333, 1.5046, 2.419):
        theirs = mitsuba_fresnel(mi, cos, eta)[:, 0]
        assert excess(fresnel_dielectric(cos, eta).F, theirs) <= 1
        assert excess(fresnel_dielectric(cos, 1 / eta).F, theirs) > 100
    c = np.linspace(0.05, 1, 20)
    theirs = [mi.fresnel_conductor(float(x), mi.Complex2f(0.2, 3.0)) for x in c]
    assert excess(fresnel_conductor(c, 3.0, 0.2), theirs) > 100                    # eta and k swapped
    assert excess(fresnel_conductor(c, *conductor_ior("Cu")), fresnel_conductor(c, *conductor_ior("Au"))) > 100


# ----------------------------------------------------------------------------- bad inputs
def test_bad_inputs_name_the_argument(raises_naming):
    nan = float("nan")
    cases = [
        (ValueError, "eta", lambda: fresnel_dielectric(0.5, -1.5)),
        (ValueError, "eta", lambda: fresnel_dielectric(0.5, 0.0)),
        (ValueError, "eta", lambda: fresnel_dielectric(0.5, nan)),
        (ValueError, "cos_theta_i", lambda: fresnel_dielectric([0.5, nan], 1.5)),
        (TypeError, "cos_theta_i", lambda: fresnel_dielectric("0.5", 1.5)),
        (TypeError, "eta", lambda: fresnel_dielectric(0.5, "bk7")),
        (TypeError, "eta", lambda: fresnel_dielectric(0.5, 1.5 + 0.1j)),
        (TypeError, "eta", lambda: fresnel_dielectric(0.5, None)),
        (ValueError, "eta", lambda: fresnel_conductor(0.5, -0.1, 1.0)),
        (ValueError, "k", lambda: fresnel_conductor(0.5, 1.0, [1.0, -1.0, 2.0])),
        (ValueError, "k", lambda: fresnel_conductor(0.5, 1.0, nan)),
        (ValueError, "cos_theta_i", lambda: fresnel_conductor(float("inf"), 1.0, 1.0)),
        (ValueError, "eta", lambda: fresnel_diffuse_reflectance(0.0)),
        (ValueError, "eta", lambda: fresnel_diffuse_reflectance([1.5, nan])),
        (TypeError, "eta", lambda: fresnel_diffuse_reflectance(None)),
        (ValueError, "w", lambda: refract([0.0, 1.0], 0.5, 1.0)),
        (ValueError, "m", lambda: refract([0.0, 0.0, 1.0], -1.0, 1.0, [0.0, 1.0])),
        (ValueError, "eta_ti", lambda: refract([0.0, 0.0, 1.0], -1.0, nan)),
        (ValueError, "int_ior", lambda: ior_value("crown glass", "int_ior")),
        (ValueError, "ext_ior", lambda: ior_value(-1.5, "ext_ior")),
        (ValueError, "int_ior", lambda: ior_value(nan, "int_ior")),
        (TypeError, "int_ior", lambda: ior_value(None, "int_ior")),
        (TypeError, "int_ior", lambda: ior_value(True, "int_ior")),
        (ValueError, "ext_ior", lambda: relative_ior("bk7", "unobtainium")),
        (ValueError, "int_ior", lambda: relative_ior(0.0, "air")),
        (TypeError, "name", lambda: ior_value(1.5, 3)),
        (ValueError, "material", lambda: conductor_ior("Gold")),
    ]
    for exc, name, call in cases:
        with raises_naming(exc, name):
            call()
    with pytest.raises(ValueError, match=r"int_ior: unknown .*acrylic glass.*bk7.*diamond"):
        relative_ior("crown glass", "air")


# ----------------------------------------------------------------------------- the probe
def test_probe_follows_vrlabs_direction_names(mi):
    """vrlab's wo = Mitsuba's si.wi: a diffuse and a rough conductor (f · cos theta of wi) agree
    with vrlab's own; swapping the arguments fails (the cosine belongs to wi)."""
    from vrlab.render.bsdfs import Diffuse, RoughConductor
    from vrlab.testing.mitsuba_bsdf import bsdf_eval_pdf, mitsuba_bsdf

    rng = np.random.default_rng(3)
    wo, wi = unit(rng.normal(size=(300, 3))), unit(rng.normal(size=(300, 3)))
    diffuse = mitsuba_bsdf({"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.2, 0.5, 0.7]}})
    value, pdf = bsdf_eval_pdf(diffuse, wo, wi)
    ref = Diffuse([0.2, 0.5, 0.7])
    assert excess(value, ref.eval(wo, wi)) <= 1
    up = (wo[:, 2] > 0) & (wi[:, 2] > 0)
    assert excess(pdf[up], ref.pdf(wo, wi)[up]) <= 1 and np.all(pdf[~up] == 0)
    b = mitsuba_bsdf({"type": "roughconductor", "alpha": 0.3, "distribution": "ggx"})
    value, _ = bsdf_eval_pdf(b, wo, wi)
    ours = RoughConductor(alpha=0.3, distribution="ggx").eval(wo, wi)
    assert excess(value, ours) <= 1
    swapped, _ = bsdf_eval_pdf(b, wi, wo)
    assert excess(swapped, ours) > 100


def test_probe_samples_uv_shapes_and_speed(mi):
    from vrlab.testing.mitsuba_bsdf import bsdf_eval_pdf, bsdf_sample, flag_names, mitsuba_bsdf

    b = mitsuba_bsdf('<bsdf version="3.0.0" type="conductor"/>')                     # material "none"
    wo = unit(np.array([[0.3, -0.2, 0.8], [0.0, 0.0, 1.0]]))
    s = bsdf_sample(b, wo, [0.1, 0.9], [[0.2, 0.3], [0.7, 0.1]])
    np.testing.assert_allclose(s.wi, mirror(wo), atol=1e-6)
    np.testing.assert_array_equal(s.weight, 1.0)
    assert s.pdf.tolist() == [1.0, 1.0] and s.eta.tolist() == [1.0, 1.0] and s.sampled_component.tolist() == [0, 0]
    assert "DeltaReflection" in flag_names(b.flags) and "FrontSide" in flag_names(b.flags)
    checker = mitsuba_bsdf({"type": "diffuse", "reflectance": {"type": "checkerboard", "color0": 0.1,
                                                               "color1": 0.9}})
    value, pdf = bsdf_eval_pdf(checker, [0, 0, 1], [0, 0, 1], uv=[[0.1, 0.1], [0.6, 0.1], [0.6, 0.6]])
    np.testing.assert_allclose(value[:, 0], np.array([0.1, 0.9, 0.1]) / np.pi, rtol=1e-6)
    assert value.shape == (3, 3) and pdf.shape == (3,)
    value, pdf = bsdf_eval_pdf(checker, np.tile([0.0, 0.0, 1.0], (2, 4, 1)), [0.0, 0.6, 0.8])
    assert value.shape == (2, 4, 3) and pdf.shape == (2, 4)
    rng = np.random.default_rng(4)
    wo, wi = unit(rng.normal(size=(1000, 3))), unit(rng.normal(size=(1000, 3)))
    g = mitsuba_bsdf({"type": "roughconductor", "material": "Au", "alpha": 0.2})
    t0 = time.perf_counter()
    bsdf_eval_pdf(g, wo, wi)
    bsdf_sample(g, wo, rng.random(1000), rng.random((1000, 2)))
    assert time.perf_counter() - t0 < 1.0


def test_probe_restores_the_variant_and_checks_its_arguments(mi, raises_naming):
    from vrlab.testing.mitsuba_bsdf import bsdf_eval_pdf, bsdf_sample, mitsuba_bsdf

    b = mitsuba_bsdf({"type": "diffuse"})
    mi.set_variant("scalar_spectral")
    try:
        value, _ = bsdf_eval_pdf(b, [0, 0, 1], [0, 0, 1])
        assert mi.variant() == "scalar_spectral" and value == pytest.approx(0.5 / np.pi)
    finally:
        mi.set_variant("scalar_rgb")
    for exc, name, call in [
        (TypeError, "spec", lambda: mitsuba_bsdf(42)),
        (ValueError, "spec", lambda: mitsuba_bsdf({"reflectance": 0.5})),
        (ValueError, "spec", lambda: mitsuba_bsdf({"type": "independent"})),
        (ValueError, "variant", lambda: mitsuba_bsdf({"type": "diffuse"}, variant="cuda_ad_rgb")),
        (TypeError, "bsdf", lambda: bsdf_eval_pdf(3, [0, 0, 1], [0, 0, 1])),
        (ValueError, "wo", lambda: bsdf_eval_pdf(b, [0, 1], [0, 0, 1])),
        (ValueError, "wi", lambda: bsdf_eval_pdf(b, [0, 0, 1], [0, 0, float("nan")])),
        (ValueError, "mode", lambda: bsdf_eval_pdf(b, [0, 0, 1], [0, 0, 1], mode="adjoint")),
        (ValueError, "u1", lambda: bsdf_sample(b, [0, 0, 1], 1.5, [0.5, 0.5])),
        (ValueError, "u2", lambda: bsdf_sample(b, [0, 0, 1], 0.5, [0.5])),
    ]:
        with raises_naming(exc, name):
            call()


def test_fresnel_is_a_helper_module_not_a_plugin():
    import vrlab.render.bsdfs as bsdfs
    from vrlab.render import registered

    assert bsdfs.fresnel_dielectric is fresnel_dielectric and "conductor_ior" in dir(bsdfs)
    assert all(getattr(bsdfs, name) is not None for name in bsdfs.__all__)
    assert all(cls.__module__ != "vrlab.render.bsdfs.fresnel" for cls in registered("bsdf").values())
