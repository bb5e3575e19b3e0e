"""The renderer runs the estimator layer's objects (issue 12): presets are estimator objects,
any estimator with per-unit values renders the closed-form scenes, a user's heuristic and
estimator plug in and travel to spawned worker processes, and wrong weights are caught."""
from __future__ import annotations

import multiprocessing as mp
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

import user_estimators
from test_render import (CENTRE_TOL, FLOOR, L_E, RECT_LIGHT, RHO, SPHERE_LIGHT, bonferroni_z, exact_image,
                         polygon_irradiance, scene)
from vrlab.estimators import (MIS, RIS, Antithetic, ControlVariate, DefensiveMixture, Estimator, MonteCarlo,
                              OneSampleMIS, Stratified)
from vrlab.render import PRESETS, PixelIntegrand, ShadingIntegrand, preset, render

SC = scene(FLOOR + RECT_LIGHT)
EXACT = exact_image("rectangle", SC)


def closed_form_z(est) -> tuple[float, float]:
    """(max |z| over pixels and channels, pooled z of the image mean) against the closed form."""
    img, se = est.value.astype(float), est.stderr.astype(float)
    se = np.sqrt(se**2 + (CENTRE_TOL * EXACT) ** 2)
    z = (img - EXACT) / se
    g, gs = img[..., 1], se[..., 1]
    return float(np.max(np.abs(z))), float((g.mean() - EXACT[..., 1].mean()) / (np.sqrt(np.sum(gs**2)) / gs.size))


ESTIMATORS = {
    "mc-cosine": lambda: MonteCarlo("cosine"),
    "mc-uniform": lambda: MonteCarlo("uniform"),
    "mc-light": lambda: MonteCarlo("light"),
    "mis-3-power": lambda: MIS(["light", "cosine", "bsdf"], heuristic="power"),
    "mis-maximum": lambda: MIS(["light", "bsdf"], heuristic="maximum"),
    "mis-cutoff": lambda: MIS(["light", "bsdf"], fractions=[2, 1], heuristic="cutoff", alpha=0.3),
    "mis-user-heuristic": lambda: MIS(["light", "bsdf"], heuristic=user_estimators.balance),
    "mis-optimal": lambda: MIS(["light", "bsdf"], heuristic="optimal"),
    "mis-optimal-3-uneven": lambda: MIS(["light", "cosine", "bsdf"], fractions=[2, 1, 1], heuristic="optimal"),
    "one-sample-balance": lambda: OneSampleMIS(["bsdf", "light"]),
    "one-sample-power": lambda: OneSampleMIS(["bsdf", "light"], probabilities=[1, 3], heuristic="power"),
    "antithetic-cosine": lambda: Antithetic("cosine"),
    "antithetic-light": lambda: Antithetic("light"),
    "defensive-controls": lambda: DefensiveMixture(["light", "bsdf"]),
    "defensive-plain": lambda: DefensiveMixture(["light"], controls=False),
    "ris-light": lambda: RIS("light", target="unshadowed", m=4),
    "ris-cosine": lambda: RIS("cosine", target="unshadowed", m=4),
    "cv-fitted": lambda: ControlVariate("lambertian", distribution="light"),
    "cv-alpha-half": lambda: ControlVariate("lambertian", alpha=0.5, distribution="light"),
    "user-estimator": lambda: user_estimators.LightBSDFMIS(),
}


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_estimator_objects_render_the_closed_form(name):
    est = render(SC, 1024, ESTIMATORS[name](), rng=3)
    assert est.value.shape == est.stderr.shape == (6, 8, 3) and est.n == 1024
    max_z, pooled = closed_form_z(est)
    assert max_z < bonferroni_z(EXACT.size), (name, max_z)
    assert abs(pooled) < 4, (name, pooled)


def test_weights_that_sum_to_two_fail():
    """The mutation: a user's estimator whose MIS weights sum to 2 renders twice the image, and
    the closed-form test sees it; MIS itself refuses a heuristic whose weights sum to 2."""
    bad = render(SC, 256, user_estimators.LightBSDFMIS(weight_scale=2.0), rng=3)
    max_z, pooled = closed_form_z(bad)
    assert max_z > bonferroni_z(EXACT.size) and abs(pooled) > 4
    with pytest.raises(ValueError, match="heuristic"):
        render(SC, 4, MIS(["light", "bsdf"], heuristic=user_estimators.doubled), rng=3)


@pytest.mark.parametrize("name", ["mis-power", "mis-balance"])
def test_a_preset_and_its_object_give_the_same_image(name):
    """A name and the object it stands for render the same image for the same seed, on a scene
    with several BSDF groups; a hand-written balance heuristic gives the balance image."""
    obj = MIS(["light", "bsdf"], heuristic=name[4:])
    a = render("cornell_box", 4, name, rng=5, width=24, height=24)
    b = render("cornell_box", 4, obj, rng=5, width=24, height=24)
    np.testing.assert_array_equal(a.value, b.value)
    np.testing.assert_array_equal(a.stderr, b.stderr)
    assert repr(preset(name)[0]) == repr(obj)
    if name == "mis-balance":
        c = render("cornell_box", 4, MIS(["light", "bsdf"], heuristic=user_estimators.balance), rng=5,
                   width=24, height=24)
        np.testing.assert_allclose(c.value, a.value, rtol=1e-5, atol=1e-7)


def test_every_preset_is_an_estimator_object():
    for name in PRESETS:
        est, units = preset(name, emitter_samples=2, bsdf_samples=3)
        assert isinstance(est, Estimator) and units >= 1
    assert preset("light", emitter_samples=2)[1] == 2 and preset("bsdf", bsdf_samples=3)[1] == 3


def test_estimator_is_pickled_to_spawned_workers():
    """A heuristic from an importable module reaches worker processes started with spawn (the
    default on macOS and Windows), and the image is the one process's."""
    sc = scene(FLOOR + RECT_LIGHT + SPHERE_LIGHT, fov=60, width=48, height=30)   # 2 tiles
    est = MIS(["light", "bsdf"], heuristic=user_estimators.balance)
    one = render(sc, 4, est, rng=9)
    with ProcessPoolExecutor(2, mp_context=mp.get_context("spawn")) as pool:
        spawned = render(sc, 4, est, rng=9, executor=pool, workers=2)
    np.testing.assert_array_equal(one.value, spawned.value)
    np.testing.assert_array_equal(one.stderr, spawned.stderr)
    with pytest.raises(TypeError, match="estimator"):
        render(sc, 4, MIS(["light", "bsdf"], heuristic=lambda q: user_estimators.balance(q)), rng=9, workers=2)


def test_antithetic_direct_lighting_variance_factor():
    """The lecture's rendering use of antithetic variates: cosine-sampled pairs (u, 1 - u) give
    directions mirrored about the normal.  Under a large light on one side (a 2 x 2 square
    standing 0.3 above the floor, 1 to the side) a pair's two terms are strongly negatively
    correlated, so at equal evaluations (one pair against two independent samples) the
    variance factor 1 + rho is well below 1 (measured 0.12 at 1024 spp).  The mutation
    (the pair's second member equal to the first, rho = 1) doubles the variance and fails."""
    side = scene(FLOOR + RECT_LIGHT.replace('<scale x="0.4" y="0.3"/>', '<scale x="1" y="1"/>')
                 .replace('x="0.1" y="1"', 'x="1.0" y="0.3"'))

    class Twins(Antithetic):
        def unit_values(self, integrand, u):          # both members at u: (Y + Y) / 2
            return MonteCarlo(self.distribution).unit_values(integrand, u)

    def factor(est):
        a = render(side, 1024, est, rng=4).stderr.astype(float) ** 2
        b = render(side, 1024, MonteCarlo("cosine"), rng=5, units=2).stderr.astype(float) ** 2
        return float(a.mean() / b.mean())

    f = factor(Antithetic("cosine"))
    assert f < 0.3, f
    assert factor(Twins("cosine")) > 1.5


def test_estimators_without_unit_values_and_bad_names_are_refused(raises_naming):
    with raises_naming(TypeError, "estimator"):
        render(SC, 4, Stratified())
    with raises_naming(TypeError, "estimator"):
        render(SC, 4, 42)
    with raises_naming(ValueError, "distribution"):
        render(SC, 4, MonteCarlo("nope"))
    with raises_naming(ValueError, "distributions[1]"):
        render(SC, 4, MIS(["light", "glossy"]))
    with raises_naming(ValueError, "optimal_pilot"):              # a pilot needs the whole sample set
        render(SC, 4, MIS(["light", "bsdf"], heuristic="optimal", optimal_pilot=0.2))
    # cross-fitted coefficients: too few units for a fit give the plain average, at any spp
    opt = render(SC, 2, MIS(["light", "bsdf"], heuristic="optimal"), rng=3)
    np.testing.assert_allclose(opt.value, render(SC, 2, "mis-balance", rng=3).value, rtol=1e-5, atol=1e-7)
    with raises_naming(ValueError, "spp"):                      # a fit's residuals need two units
        render(SC, 1, ControlVariate("lambertian", distribution="light"), rng=3)
    two = render(SC, 2, ControlVariate("lambertian", distribution="light"), rng=3)
    assert np.all(np.isfinite(two.value)) and np.all(np.isfinite(two.stderr))


def test_shading_integrand_techniques_are_distributions_with_exact_densities():
    """At floor points under the rectangle light: every technique's samples are points
    (w, j); f / p averages to the closed-form direct lighting for each technique, and the
    BSDF-side densities vanish at light samples hidden behind a blocker."""
    integ = PixelIntegrand(SC, "light")
    x0 = np.array([[0.1, 0.0, 0.0], [-0.2, 0.0, 0.1]], np.float32)
    n = np.tile(np.float32([0, 1, 0]), (2, 1))
    wo = np.tile(np.float32([0, 1, 0]), (2, 1))
    sh = integ.shading(0, x0, n, wo)
    assert isinstance(sh, ShadingIntegrand) and set(sh.techniques) == {"bsdf", "light", "cosine", "uniform", "bsdf:diffuse"}
    corner, e1, e2, _ = SC.shapes[1].rectangle()
    verts = np.array([corner, corner + e1, corner + e1 + e2, corner + e2])
    exact = RHO[1] / np.pi * polygon_irradiance(x0.astype(float), np.array([0.0, 1.0, 0.0]), verts, L_E)
    g = np.random.default_rng(0)
    for name, tech in sh.techniques.items():
        u = g.random((2, 200_000, tech.dim_u))
        x = tech.sample(u)
        assert x.shape == (2, 200_000, 5) and np.all(x[..., 4] == 0)          # no delta lobes
        v = sh(x) / np.maximum(tech.pdf(x), 1e-30)[None]
        est = v.mean(-1)[1]                       # green channel, both points
        se = v.std(-1)[1] / np.sqrt(200_000)
        assert np.all(np.abs(est - exact) < 5 * se + 1e-4 * exact), (name, est, exact, se)


def test_points_take_vrlab_and_scipy_engines_as_classes_or_instances(raises_naming):
    """``points=`` drives the pixels' primary-sample-space uniforms: SciPy's engines (class or
    instance of the right dimension) and vrlab's, as a shared set shifted per pixel; over
    independent seeds the images average to the closed form."""
    from scipy.stats import qmc

    from vrlab.points import Halton, PaddedStratified

    dim = PixelIntegrand(SC, "light").dim
    for points in (qmc.Sobol, qmc.Halton(dim, rng=4), Halton, PaddedStratified(dim, rng=2), "halton"):
        reps = np.array([render(SC, 16, "light", rng=[8, r], points=points).value for r in range(12)])
        mean, se = reps.mean(0), reps.std(0, ddof=1) / np.sqrt(len(reps))
        z = (mean[..., 1] - EXACT[..., 1]) / np.sqrt(se[..., 1] ** 2 + (CENTRE_TOL * EXACT[..., 1]) ** 2)
        assert abs(z.mean() * np.sqrt(z.size)) < 4 + 2, points                 # pooled, t with 11 dof
        assert render(SC, 4, "light", rng=0, points=points).extra["stderr_note"]
    with raises_naming(ValueError, "points"):
        render(SC, 4, "light", points=qmc.Sobol(dim + 1, rng=0))


@pytest.mark.parametrize("est", ["mis-power", "ris", "cv", "mixture", Antithetic("cosine")])
def test_pixel_samples_leave_no_cyclic_garbage(est):
    """A block's rays are freed when it is done, not at the next cyclic garbage collection:
    a cycle (integrand -> technique -> integrand) kept ~3.5 MB per tile alive and cost page
    faults in every worker."""
    import gc

    from vrlab.render import builtin_scene_path, load_scene

    pix = PixelIntegrand(load_scene(builtin_scene_path("cornell_box")), est)
    pixels = np.stack(np.divmod(np.arange(0, 256 * 256, 997), 256), -1)     # every BSDF group, light, sky
    u = np.random.default_rng(0).random((len(pixels), 8, pix.dim))
    pix.outputs(pixels, u)
    gc.collect()
    gc.disable()
    try:
        gc.set_debug(gc.DEBUG_SAVEALL)
        pix.outputs(pixels, u)
        gc.collect()
        # vrlab objects only: threads left by other tests (Dask, tqdm) may make garbage meanwhile
        ours = sorted({type(o).__name__ for o in gc.garbage if type(o).__module__.startswith("vrlab")})
    finally:
        gc.set_debug(0)
        gc.garbage.clear()
        gc.enable()
    assert not ours, f"vrlab objects in reference cycles after a block: {ours}"


def test_pixels_with_nothing_to_shade_keep_the_estimators_columns():
    """A camera that sees only the sky: every block has nothing to shade, and estimators with
    several output columns (optimal MIS with its emitted column, fitted controls) still give the
    sky's radiance."""
    from vrlab.render import load_scene

    sky = scene('<shape type="sphere"><point name="center" value="0, 5, 0"/><float name="radius" value="0.2"/></shape>'
                '<emitter type="constant"><rgb name="radiance" value="0.3, 0.5, 0.7"/></emitter>',
                origin="0, 0.5, 0", target="0, -1, 0", up="0, 0, -1")
    sc = load_scene(sky) if isinstance(sky, str) else sky
    for est in (MIS(["light", "bsdf"], heuristic="optimal"), DefensiveMixture(["light", "bsdf"]), "mis-power"):
        img = render(sc, 4, est, rng=0)
        assert np.allclose(img.value, [0.3, 0.5, 0.7]), est


class _NaNOutputs(MonteCarlo):
    """A user's estimator whose unit values turn NaN (e.g. 0/0 in its own weights)."""

    def unit_values(self, integrand, u):
        return np.full_like(super().unit_values(integrand, u), np.nan)


class _ComplexOutputs(MonteCarlo):
    def unit_values(self, integrand, u):
        return super().unit_values(integrand, u) + 0j


@pytest.mark.parametrize("cls, exc, words", [(_NaNOutputs, ValueError, "non-finite"),
                                             (_ComplexOutputs, TypeError, "real numbers")])
def test_a_users_estimator_with_nan_or_complex_outputs_is_refused(raises_naming, cls, exc, words):
    """Before: a NaN image without a word, and complex values cast to real with a warning."""
    from vrlab.render import builtin_scene_path, load_scene

    with raises_naming(exc, "estimator", words):
        render(load_scene(builtin_scene_path("cornell_box")), 2, cls("light"), rng=0, width=8, height=6)
