"""Metropolis--Hastings: a deterministic function of its uniforms; the chains' states converge to
the normalised density (chi-square on the independent final states, total variation falling with
steps); two separated blobs are not explored without large steps but are with them; E_pi[g] and
int f with batch-means errors; a wrong acceptance ratio is detected."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import vrlab.integrands as I
from vrlab.distributions import PiecewiseConstant2D
from vrlab.estimators.metropolis import MetropolisHastings, sample_histogram
from vrlab.integrands import Integrand
from vrlab.testing import pooled_chi2

ALPHA = 1e-3


def image_target(seed=0, shape=(8, 8)):
    img = np.random.default_rng(seed).random(shape) ** 2 + 0.05
    img[2:4, 5:7] = 0.0                           # a hole: pi = 0 there
    return PiecewiseConstant2D(img)


def fast_pdf(pc: PiecewiseConstant2D):
    """The same density as ``pc.pdf`` on the unit square by direct cell lookup (fast for loops)."""
    def pdf(x):
        ix = np.minimum((x[..., 0] * pc.nx).astype(np.int64), pc.nx - 1)
        iy = np.minimum((x[..., 1] * pc.ny).astype(np.int64), pc.ny - 1)
        return pc.density[iy, ix]
    return pdf


def cell_probs(pc: PiecewiseConstant2D) -> np.ndarray:
    """Cell probabilities in histogramdd order [ix, iy]."""
    return (pc.image / pc.image.sum()).T


def tv(samples, pc) -> float:
    dens, _ = sample_histogram(samples, bins=(pc.nx, pc.ny))
    return 0.5 * float(np.abs(dens / (pc.nx * pc.ny) - cell_probs(pc)).sum())


def two_blobs(x):
    """Two discs of radius 0.1 around (0.25, 0.25) and (0.75, 0.75); zero in between."""
    a = np.sum((x - 0.25) ** 2, -1) < 0.01
    b = np.sum((x - 0.75) ** 2, -1) < 0.01
    return a * 1.0 + b * 2.0


def in_b(x):
    return np.sum((x - 0.75) ** 2, -1) < 0.01


def test_deterministic_function_of_uniforms():
    pc = image_target()
    mh = MetropolisHastings(pc.pdf, step=0.05, large_step_prob=0.2)
    T, C, burn = 40, 7, 5
    run = mh.run(T, C, rng=123, burn_in=burn)
    u = np.random.default_rng(123).random((1 + burn + T, C, mh.dim_step))
    ch = mh.chain(u, burn_in=burn)
    np.testing.assert_array_equal(run.samples, ch.samples)
    assert run.samples.shape == (T, C, 2) and run.target.shape == (T, C)
    np.testing.assert_array_equal(run.target, pc.pdf(run.samples))
    assert 0 < run.acceptance < 1 and run.burn_in == burn
    assert np.all((run.samples >= 0) & (run.samples < 1))
    # same seed -> same chains; another seed -> other chains
    np.testing.assert_array_equal(mh.run(T, C, rng=123, burn_in=burn).samples, run.samples)
    assert not np.array_equal(mh.run(T, C, rng=124, burn_in=burn).samples, run.samples)
    # rejected proposals repeat the state: states change only on acceptance
    moved = np.any(np.diff(ch.samples, axis=0) != 0, -1)
    assert 0 < moved.mean() < 1


@pytest.mark.parametrize("boundary", ["wrap", "reject"])
def test_final_states_follow_density(boundary):
    """The final states of independent chains are i.i.d.: a real chi-square test against pi/b."""
    pc = image_target()
    mh = MetropolisHastings(pc.pdf, step=0.08, large_step_prob=0.1, boundary=boundary)
    run = mh.run(1, 6000, rng=1, burn_in=150)
    counts, _ = np.histogramdd(run.samples[-1], bins=(pc.nx, pc.ny), range=[(0, 1), (0, 1)])
    res = pooled_chi2(counts, 6000 * cell_probs(pc))
    assert res.pvalue > ALPHA, res
    assert counts.T[2:4, 5:7].sum() == 0                  # never in the hole


def test_total_variation_decreases_with_steps():
    pc = image_target(seed=3)
    mh = MetropolisHastings(pc.pdf, step=0.03, large_step_prob=0.02)
    C = 8000
    tvs = [tv(mh.run(1, C, rng=5, burn_in=t).samples[-1], pc) for t in (0, 4, 30, 200)]
    assert tvs[0] > tvs[1] > tvs[2] > tvs[3], tvs
    assert tvs[0] > 0.15 and tvs[3] < 0.05, tvs
    # the pooled histogram of a long run (dependent samples) gets close too
    long = mh.run(400, 256, rng=6, burn_in=100)
    assert tv(long.samples, pc) < 0.05
    dens, edges = sample_histogram(long.samples, bins=(8, 8))
    assert np.sum(dens) / 64 == pytest.approx(1.0) and len(edges) == 2


def test_disconnected_blobs_need_large_steps():
    start = np.array([0.25, 0.25])
    local = MetropolisHastings(two_blobs, step=0.02, large_step_prob=0.0)
    run = local.run(3000, 32, rng=2, burn_in=0, x0=start)
    assert not np.any(in_b(run.samples))                 # stuck in the starting blob
    assert np.all(two_blobs(run.samples) == 1.0)
    mixing = MetropolisHastings(two_blobs, step=0.02, large_step_prob=0.1)
    run = mixing.run(3000, 32, rng=2, burn_in=500, x0=start)
    share = in_b(run.samples).mean()
    # blob B has twice the density on the same area: 2/3 of the mass
    assert share == pytest.approx(2 / 3, abs=0.05), share
    assert run.acceptance_large < 0.2 and run.acceptance_small > 0.5


def test_expectation_unbiased_and_calibrated():
    pc = image_target()
    xc = (np.arange(pc.nx) + 0.5) / pc.nx
    exact = float((cell_probs(pc).sum(1) * xc).sum())            # E[x] under pi
    u = np.random.default_rng(0).random((1000, 2))
    np.testing.assert_array_equal(fast_pdf(pc)(u), pc.pdf(u))
    mh = MetropolisHastings(fast_pdf(pc), step=0.1, large_step_prob=0.2, burn_in=60)
    reps = [mh.expectation(lambda x: x[..., 0], 200, 16, rng=s) for s in np.random.SeedSequence(4).spawn(50)]
    vals = np.array([e.value for e in reps])
    z = (vals - exact) / np.array([e.stderr for e in reps])
    assert abs(vals.mean() - exact) < 4 * vals.std(ddof=1) / np.sqrt(len(vals))
    # chain means are i.i.d. across chains: t_15 z-scores
    p = stats.kstest(stats.t.cdf(z, 15), "uniform").pvalue
    assert p > ALPHA, (p, z.std())
    # batch means within chains (batches >> autocorrelation time) agree
    e = mh.expectation(lambda x: x[..., 0], 3000, 8, rng=9, batches=10)
    assert e.n == 80 and abs(e.value - exact) < 4 * e.stderr
    assert e.extra["batches"] == 10 and 0 < e.extra["acceptance"] < 1


# glossy-light (and its in-span twin) has its own test: a tiny bright light holding ~10 % of the
# integral takes thousands of steps to find (large steps hit it with probability 1/1024)
BOX = [name for name in I.names() if I.get(name).bounds is not None and I.get(name).dim == 2
       and not name.startswith("glossy-light")] + ["sin-01"]


def box_integrand(name):
    if name == "sin-01":   # a 2D version of the 1D lab integrand on the unit square
        return Integrand(lambda x: np.sin(np.pi * x[..., 0]) * (1 + x[..., 1]), [(0, 1), (0, 1)], 3 / np.pi)
    return I.get(name)


@pytest.mark.parametrize("name", BOX)
def test_integral_with_estimated_normalisation(name):
    """int f = b E_pi[f/pi] with pi = |f| + 0.2 mean|f| (unnormalised), b estimated separately."""
    it = box_integrand(name)
    scale = 0.2 * abs(it.exact)
    mh = MetropolisHastings(lambda x: np.abs(it(x)) + scale, step=0.05, large_step_prob=0.2, n_chains=32,
                            burn_in=50)
    ests = [mh.estimate(it, 32 * 150, rng=s) for s in np.random.SeedSequence(7).spawn(30)]
    vals = np.array([e.value for e in ests])
    se = np.array([e.stderr for e in ests])
    assert abs(vals.mean() - it.exact) < 4 * vals.std(ddof=1) / np.sqrt(len(vals))
    z = (vals - it.exact) / se
    lo, hi = np.sqrt(stats.chi2.ppf([ALPHA / 2, 1 - ALPHA / 2], len(z) - 1) / (len(z) - 1))
    assert lo < z.std(ddof=1) < hi * 1.1, z.std(ddof=1)
    e = ests[0]
    assert e.extra["normalization"] > 0 and e.extra["normalization_stderr"] > 0
    assert e.n_evals == 32 * 150


def test_glossy_light_short_chains_biased_long_chains_fine():
    """MH is consistent, not unbiased: short chains started uniformly have not yet found the small
    bright light (burn-in bias, detected); long chains with frequent large steps have."""
    it = I.get("glossy-light")
    target = lambda x: np.abs(it(x)) + 0.2 * it.exact  # noqa: E731
    short = MetropolisHastings(target, step=0.05, large_step_prob=0.2, n_chains=32, burn_in=50)
    vals = np.array([short.estimate(it, 32 * 150, rng=s).value for s in np.random.SeedSequence(7).spawn(30)])
    assert vals.mean() + 4 * vals.std(ddof=1) / np.sqrt(len(vals)) < it.exact
    long = MetropolisHastings(target, step=0.05, large_step_prob=0.5, n_chains=32, burn_in=300)
    e = long.estimate(it, 32 * 3000, rng=1)
    assert abs(e.value - it.exact) < 4 * e.stderr


def test_integral_with_known_normalisation():
    pc = image_target()
    it = Integrand(lambda x: pc.pdf(x) * np.cos(3 * x[..., 1]), [(0, 1), (0, 1)], None)
    yc = np.arange(pc.ny)
    # int pdf(x) cos(3y) = sum_cells p_cell * mean of cos(3y) over the cell's y-range
    cell_cos = (np.sin(3 * (yc + 1) / pc.ny) - np.sin(3 * yc / pc.ny)) * pc.ny / 3
    exact = float((cell_probs(pc) * cell_cos[None, :]).sum())
    mh = MetropolisHastings(pc.pdf, step=0.08, large_step_prob=0.2, normalization=1.0, n_chains=64)
    e = mh.estimate(it, 64 * 500, rng=3)
    assert abs(e.value - exact) < 4 * e.stderr
    assert e.extra["normalization"] == 1.0 and e.extra["normalization_stderr"] == 0.0
    b = mh.normalizer(100_000, rng=1)
    assert abs(b.value - 1.0) < 4 * b.stderr


class SqrtAcceptance(MetropolisHastings):
    """A wrong acceptance ratio: min(1, sqrt(pi(y) / pi(x))) -- samples from sqrt(pi), not pi."""

    def _pi(self, x):
        return np.sqrt(super()._pi(x))


def test_wrong_acceptance_is_detected():
    pc = image_target()
    bad = SqrtAcceptance(pc.pdf, step=0.08, large_step_prob=0.1)
    run = bad.run(1, 6000, rng=1, burn_in=150)
    counts, _ = np.histogramdd(run.samples[-1], bins=(8, 8), range=[(0, 1), (0, 1)])
    assert pooled_chi2(counts, 6000 * cell_probs(pc)).pvalue < ALPHA


def test_bad_inputs():
    f = lambda x: np.ones(x.shape[:-1])  # noqa: E731
    with pytest.raises(ValueError, match="step"):
        MetropolisHastings(f, step=0)
    with pytest.raises(ValueError, match="step"):
        MetropolisHastings(f, step=-0.1)
    with pytest.raises(ValueError, match="large_step_prob"):
        MetropolisHastings(f, large_step_prob=1.5)
    with pytest.raises(ValueError, match="large_step_prob"):
        MetropolisHastings(f, large_step_prob=-0.1)
    with pytest.raises(TypeError, match="step"):
        MetropolisHastings(f, step="big")
    with pytest.raises(ValueError, match="boundary"):
        MetropolisHastings(f, boundary="bounce")
    with pytest.raises(TypeError, match="target"):
        MetropolisHastings(3.0)
    with pytest.raises(ValueError, match="domain"):
        MetropolisHastings(f, domain=[(0, 1), (1, 0)])
    with pytest.raises(ValueError, match="n_chains"):
        MetropolisHastings(f, n_chains=0)
    with pytest.raises(ValueError, match="normalization"):
        MetropolisHastings(f, normalization=-1.0)
    mh = MetropolisHastings(f)
    with pytest.raises(ValueError, match="target"):
        MetropolisHastings(lambda x: -np.ones(x.shape[:-1])).run(5, 2, rng=0)
    with pytest.raises(ValueError, match="target"):
        MetropolisHastings(lambda x: np.ones(3)).run(5, 2, rng=0)
    with pytest.raises(ValueError, match="u"):
        mh.chain(np.zeros((5, 2, 3)))
    with pytest.raises(ValueError, match="x0"):
        mh.run(5, 2, rng=0, x0=[1.5, 0.5])
    with pytest.raises(ValueError, match="n_steps"):
        mh.run(0, 2, rng=0)
    with pytest.raises(ValueError, match="integrand"):
        mh.estimate(I.get("exp"), 1000, rng=0)
    with pytest.raises(ValueError, match="n"):
        mh.estimate(I.get("smooth-2d"), 10, rng=0)
    with pytest.raises(TypeError):
        mh.unit_values(I.get("smooth-2d"), np.zeros((3, 2)))
    # a 3D box works too
    mh3 = MetropolisHastings(lambda x: np.exp(-np.sum(x, -1)), domain=[(0, 1)] * 3)
    run = mh3.run(50, 4, rng=0)
    assert run.samples.shape == (50, 4, 3) and mh3.dim_step == 5
