"""Importing the renderer must not pull in the slow SciPy modules (whole-process time of
``vrlab render`` is benchmarked against Mitsuba, see benchmarks/bench_mitsuba.py)."""
import ast
import subprocess
import sys


def test_render_import_does_not_load_scipy_stats_or_pandas():
    code = ("import sys, vrlab, vrlab.render, vrlab.render.film; "
            "print(sorted(m for m in ('scipy.stats', 'pandas', 'matplotlib', 'scipy.special') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out


def test_lazy_testing_attribute():
    import vrlab
    assert vrlab.testing.chi2_gof is not None


def test_render_import_loads_only_the_estimators_it_uses():
    """Importing the renderer loads no estimator or point-set module; a render loads the
    ones its estimator and points need (mis-power with i.i.d. points: MIS and its base)."""
    code = ("import sys, vrlab.render.film; mods = lambda: sorted(m for m in sys.modules if m.startswith("
            "('vrlab.estimators.', 'vrlab.points.'))); print(mods()); "
            "vrlab.render.film.render('furnace', 2, width=4, height=3, rng=0); print(mods())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    at_import, after = out.strip().splitlines()
    assert at_import == "[]", out
    loaded = ast.literal_eval(after)           # the printed list of module names
    assert [m for m in loaded if m.startswith("vrlab.estimators.")] == [
        "vrlab.estimators._recipe_tools", "vrlab.estimators.base", "vrlab.estimators.crossfit",
        "vrlab.estimators.heuristics", "vrlab.estimators.hooks", "vrlab.estimators.mis",
        "vrlab.estimators.registry", "vrlab.estimators.regression"], out
    assert not {"vrlab.points.sobol", "vrlab.points.halton", "vrlab.points.lhs"} & set(loaded), out


def test_lazy_packages_resolve_every_public_name():
    import pytest

    import vrlab
    for pkg in (vrlab.estimators, vrlab.points):
        for name in pkg.__all__:
            assert getattr(pkg, name) is not None
            assert name in dir(pkg)
        with pytest.raises(AttributeError, match="no attribute"):
            pkg.not_a_name
    assert vrlab.Integrand is vrlab.integrands.Integrand


def test_screened_poisson_is_public_and_lazy():
    code = ("import sys, vrlab.render as r; before = 'scipy.fft' in sys.modules; f = r.screened_poisson; "
            "print(before, 'screened_poisson' in dir(r), f.__module__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "True", "vrlab.render.poisson"], out
