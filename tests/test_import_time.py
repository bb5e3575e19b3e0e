"""Importing the renderer must not pull in the slow SciPy modules (whole-process time of
``vrlab render`` is benchmarked against Mitsuba, see benchmarks/bench_mitsuba.py)."""
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
    code = ("import sys, vrlab.render.film; "
            "print(sorted(m for m in sys.modules if m.startswith(('vrlab.estimators.', 'vrlab.points.'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == str(["vrlab.estimators.base", "vrlab.estimators.mis", "vrlab.estimators.ris",
                               "vrlab.points.base"]), out


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
