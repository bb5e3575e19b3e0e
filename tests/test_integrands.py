"""The catalogue's closed forms agree with independent quadrature."""
import numpy as np
import pytest

import vrlab.integrands as I
from vrlab.integrands.theory import chart_for
from vrlab.testing import integrate

NAMES = I.names()


@pytest.mark.parametrize("name", I.names(atoms=False))     # point masses: tests/test_point_masses.py
def test_exact_and_f2_match_quadrature(name):
    it = I.get(name)
    chart = chart_for(it)
    bins = 400 if it.dim == 1 else 128
    # the disk indicator's curved edge cuts cells: quadrature is only ~1e-4 accurate there
    tol = 5e-4 if name == "disk-indicator" else 1e-7
    assert integrate(it, chart, bins, quad=8) == pytest.approx(it.exact, rel=tol)
    assert integrate(lambda x: it(x) ** 2, chart, bins, quad=8) == pytest.approx(it.f2, rel=tol)


@pytest.mark.parametrize("name", NAMES)
def test_theory_variances_match_quadrature(name):
    it = I.get(name)
    for key, value in it.theory.items():
        if key.startswith("var:"):
            dist = it.techniques[key.split(":")[1]]
            assert I.mc_variance(it, dist) == pytest.approx(value, rel=1e-6, abs=1e-9)


def test_golden_numbers_for_exp():
    th = I.get("exp").theory
    assert th["var:uniform"] == pytest.approx(0.242036, abs=1e-6)
    assert th["antithetic_factor"] == pytest.approx(0.03233, abs=1e-5)
    assert th["cv_x:beta"] == pytest.approx(1.6903, abs=1e-4)
    assert th["cv_x:factor"] == pytest.approx(0.01628, abs=1e-5)


def test_lecture_examples():
    # x^2 1[x > 1/2]: sampling [1/2, 1] instead of [0, 1] lowers the variance by (|A| - |B|) int f^2 = 31/320
    it = I.get("step-x2")
    assert it.exact == pytest.approx(7 / 24)
    assert it.theory["var:uniform"] - it.theory["var:half"] == pytest.approx(31 / 320)
    # sin x with p2 = 8x/pi^2 is far better than uniform p1 = 2/pi
    s = I.get("sin").theory
    assert s["var:linear"] < s["var:uniform"] / 10


def test_glossy_light_each_technique_wins_on_one_part():
    it = I.get("glossy-light")
    toy = it.f
    brdf, light = it.techniques["brdf"], it.techniques["light"]
    lights = toy.lights

    def part(k):  # the integrand restricted to light k
        (x0, x1), (y0, y1), L = lights[k]
        return I.Integrand(lambda x: toy(x) * ((x[..., 0] >= x0) & (x[..., 0] <= x1)
                                               & (x[..., 1] >= y0) & (x[..., 1] <= y1)), [(0, 1), (0, 1)])

    big, small = part(0), part(1)
    assert I.mc_variance(big, brdf, bins=64) < I.mc_variance(big, light, bins=64) / 3
    assert I.mc_variance(small, light, bins=64) < I.mc_variance(small, brdf, bins=64) / 3


@pytest.mark.parametrize("settings, exc, name", [
    ({"center": (0.0, 0.5)}, ValueError, "center[0]"), ({"center": 0.5}, TypeError, "center"),
    ({"sigma": 0.0}, ValueError, "sigma"), ({"k_s": -1.0}, ValueError, "k_s"),
    ({"k_s": 0.0, "k_d": 0.0}, ValueError, "k_d"), ({"lights": []}, TypeError, "lights"),
    ({"lights": [((0.5, 0.2), (0, 1), 1.0)]}, ValueError, "lights[0]"),
    ({"lights": [((0, 1), (0, 1), 0.0)]}, ValueError, "lights[0][2]"),
    ({"lights": [((0, 0.5), (0, 0.5), 1.0), ((0.4, 0.6), (0.4, 0.6), 2.0)]}, ValueError, "lights"),
])
def test_glossy_light_settings_are_checked(raises_naming, settings, exc, name):
    with raises_naming(exc, name):
        I.GlossyLight(**settings)


def test_glossy_light_closed_forms_follow_the_lobe():
    """Moving the lobe changes int f as the closed form says: with the lobe deep inside the big
    light (L = 1) int f = k_s + k_d sum_k L_k |A_k| up to the lobe's tails beyond 4.8 sigma
    (8e-7 of its mass); the default lobe
    loses the unlit part, k_s (1 - Phi((x1 - c) / sigma)) with x1 the light's right edge."""
    from scipy import stats

    toy = I.GlossyLight()
    (_, x1), _, _ = toy.lights[0]
    power = sum((b - a) * (d - c) * L for (a, b), (c, d), L in toy.lights)
    inside = I.get("glossy-light-in-span").exact
    assert inside == pytest.approx(toy.k_s + toy.k_d * power, rel=2e-6)
    lit = stats.norm.cdf((x1 - toy.center[0]) / toy.sigma)      # the other sides are > 5 sigma away
    assert I.get("glossy-light").exact == pytest.approx(toy.k_s * lit + toy.k_d * power, rel=1e-6)


def test_integrand_validation():
    with pytest.raises(ValueError, match="domain"):
        I.Integrand(np.sin, "torus")
    with pytest.raises(ValueError, match="a < b"):
        I.Integrand(np.sin, [(1, 0)])
    with pytest.raises(TypeError, match="callable"):
        I.Integrand(3.0, [(0, 1)])
    with pytest.raises(ValueError, match="unknown integrand"):
        I.get("nope")


@pytest.mark.parametrize("bad, exc", [("nope", ValueError), ("", ValueError), ("EXP", ValueError),
                                      (3, TypeError), (None, TypeError), (["exp"], TypeError)])
def test_catalogue_get_names_the_argument(raises_naming, bad, exc):
    with raises_naming(exc, "name") as info:
        I.get(bad)
    assert "sin, step-x2, exp" in str(info.value)   # the valid names are listed
