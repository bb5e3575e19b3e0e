"""Helpers shared by the test modules."""
from __future__ import annotations

import contextlib
import re

import numpy as np
import pytest

from vrlab.estimators import ReSTIR


@contextlib.contextmanager
def _raises_naming(exc, *names: str):
    """``pytest.raises(exc)`` that also checks that the message names every one of ``names``
    (whole words, so ``n`` does not match inside ``integrand``)."""
    with pytest.raises(exc) as info:
        yield info
    message = str(info.value)
    for name in names:
        assert re.search(rf"(?<![\w.]){re.escape(name)}(?!\w)", message), \
            f"the message does not name {name!r}: {message!r}"


@pytest.fixture
def raises_naming():
    """Context manager: ``with raises_naming(ValueError, "alpha"): ...`` fails unless the
    block raises ``ValueError`` whose message names ``alpha``."""
    return _raises_naming


# -- calibration of an estimator from R independent replicates ---------------------------
CAL_N, CAL_R = 4000, 200          # evaluations per estimate, replicates


def replicate(est, integrand, n=CAL_N, r=CAL_R, seed=0):
    """R independent estimates in one batched call: ``points`` = uniforms (R, m, d)."""
    import numpy as np

    m = n // est.evals_per_unit
    u = np.random.default_rng(seed).random((r, m, est.dim_u(integrand)))
    return est.estimate(integrand, n, points=u)


def check_calibrated(est, integrand, unit_var=None, *, exact=None, n=CAL_N, r=CAL_R, seed=0):
    """Unbiased (pooled, 4 standard errors), z-scores with a standard deviation in the
    chi-square band, and, given ``unit_var`` (the variance of one sample unit in closed
    form), the replicates' variance in the band around unit_var / units.  A unit_var below
    1e-20 means a zero-variance estimator: every replicate must equal ``exact``.
    ``exact`` defaults to ``integrand.exact``."""
    import numpy as np

    e = replicate(est, integrand, n, r, seed)
    vals, se = np.asarray(e.value), np.asarray(e.stderr)
    exact = integrand.exact if exact is None else exact
    if unit_var is not None and unit_var < 1e-20:
        assert np.allclose(vals, exact, rtol=1e-10, atol=1e-12)
        return e
    assert_calibrated(vals, se, exact, None if unit_var is None else unit_var / e.n)
    return e


def assert_calibrated(vals, se, exact, expected_var=None):
    """Replicate estimates ``vals`` with standard errors ``se``: the mean within 4 pooled
    standard errors of ``exact``, the z-scores' standard deviation in the chi-square band
    (so the standard errors are honest), and, given ``expected_var`` (the variance of one
    estimate in closed form), the replicates' variance in that band around it."""
    import numpy as np

    from vrlab.testing.stats import std_band

    r = len(vals)
    pooled = vals.std(ddof=1) / np.sqrt(r)
    assert abs(vals.mean() - exact) < 4 * pooled, (vals.mean(), exact, pooled)
    z = (vals - exact) / se
    lo, hi = std_band(r)
    assert lo < z.std(ddof=1) < hi * 1.05, z.std(ddof=1)
    if expected_var is not None:
        ratio = vals.var(ddof=1) / expected_var
        assert lo**2 < ratio < hi**2, ratio


def render_pair(*args, **kwargs):
    """``vrlab.render.render(...)`` as ``(image, stderr)``, for tests that compare both."""
    from vrlab.render import render

    est = render(*args, **kwargs)
    return est.value, est.stderr


def run_cli(capsys, argv):
    """``vrlab`` with ``argv`` in this process: ``(exit code, stdout, stderr)``."""
    from vrlab.cli import main

    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


class InFrame:
    """A world direction distribution seen in the frame whose +z is ``axis`` (for the cap
    charts of the direction chi-square tests)."""

    dim_u = 2

    def __init__(self, dist, axis):
        self.dist, self.axis = dist, axis

    def sample(self, u):
        from vrlab.distributions.frames import to_local

        return to_local(self.dist.sample(u), self.axis)

    def pdf(self, w):
        from vrlab.distributions.frames import to_world

        return self.dist.pdf(to_world(w, self.axis))


@pytest.fixture
def mi_rgb():
    """Mitsuba 3 in its ``scalar_rgb`` variant (the test is skipped where Mitsuba is not installed)."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    return mi


# ---------------------------------------------------------------------------------------
# ReSTIR mutations that the lab and render tests must catch
# ---------------------------------------------------------------------------------------
class DroppedJacobian(ReSTIR):
    """A mistake: the shift's Jacobian left out (J = 1; in the renderer the reconnection's
    G_c / G_s)."""

    def shift_map(self, x, src, dst):
        z, J = super().shift_map(x, src, dst)
        return z, np.ones_like(J)


class WrongPixelTarget(ReSTIR):
    """A mistake: the neighbour's p̂ used where the receiving pixel's is needed."""

    def receiving_target(self, view, y, src, dst, f_dst):
        return np.where(view.nonzero(f_dst), view.phat(y, src), 0.0)
