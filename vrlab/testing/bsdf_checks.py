"""``check_bsdf``: the common checks every BSDF element must pass (as :func:`check_estimator`
for estimators).

``check_bsdf(name_or_class, **params)`` builds the BSDF (a registered name, a class, or an
instance without parameters) and runs, in order, raising ``AssertionError`` whose message starts
with ``check_bsdf[<check>]``:

``params``       bad parameters refused, naming them (:mod:`vrlab.testing.elements`);
``sample``       ``sample(wo, u)`` gives finite unit directions, weights and pdfs of the right
                 shapes, and the directions of ``sample_lobe`` (same uniforms);
``weight``       every sample's weight is eval / pdf (f cos theta_i over the density: the
                 protocol of :mod:`vrlab.render.bsdfs.base`) and its pdf is ``pdf(wo, wi)``; a
                 delta lobe's is ``delta_value / P_k``;
``chi2``         the sampled directions against ``pdf`` on a sphere chart whose pole is the
                 sample of highest density (a lobe's peak, or
                 the integrable 1 / |wi + wo| peak of microfacet sampling by the full NDF), with the shipped harness
                 (:func:`~vrlab.testing.cell_integrals`, :func:`~vrlab.testing.pooled_chi2`):
                 expected counts n x the pdf's cell integrals, not renormalised, plus one cell
                 for the delta lobes' atoms (n x their probability) and one for samples with
                 pdf 0 (the rest); Šidák over the incident directions;
``mass``         the pdf integrates, over the sphere, to the share of samples that are valid
                 (a continuous lobe's, pdf > 0): |integral - share| < 5 sigma + 0.005;
``reciprocity``  where the model declares ``reciprocal`` (default True): f(wo, wi) = f(wi, wo)
                 (without the cosine) on random pairs of the whole sphere; dielectrics (the
                 eta^2 of radiance transport), normal and bump maps (their frame depends on wo)
                 are not, as in Mitsuba 3;
``energy``       white furnace: for incident directions above the surface, the mean sample
                 weight (the albedo) is at most 1 + 5 sigma + 0.002 per channel;
``mitsuba``      with Mitsuba 3 installed and a plugin of the same name: eval and pdf equal
                 Mitsuba's (``scalar_rgb``, :mod:`vrlab.testing.mitsuba_bsdf`) on random pairs
                 (pdf where Mitsuba's eval is positive: vrlab's covers the whole sphere; for a
                 transmitting model only pdf >= Mitsuba's, whose pdf leaves out the samples it
                 rejects, e.g. refractions that stay on wo's side).

The incident directions are theta = 0.35, 0.95 and 1.3 rad (and pi - 0.6 for BSDFs that
reflect from below); ``samples`` each (default 40 000).  Returns ``{check: "ok" | "skipped:
why"}``.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .elements import NoSpec, RotatedChart, build_element, check_params, mitsuba_available, mitsuba_spec, unit_rows

__all__ = ["check_bsdf", "INCIDENT_THETAS"]

WHO = "check_bsdf"
INCIDENT_THETAS = (0.35, 0.95, 1.3)
BELOW_THETA = np.pi - 0.6
BINS = (32, 32)
SUB = 2                  # 2 x 2 sub-cells per cell: narrow refraction peaks integrate to 0.1 %


def _fail(check: str, message: str) -> AssertionError:
    return AssertionError(f"{WHO}[{check}]: {message}")


def _direction(theta: float, phi: float = 0.3) -> np.ndarray:
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


def _incident(bsdf) -> list[np.ndarray]:
    out = [_direction(t) for t in INCIDENT_THETAS]
    below = _direction(BELOW_THETA)
    if np.any(np.asarray(bsdf.eval(np.broadcast_to(below, (256, 3)), unit_rows(256, 1))) > 0):
        out.append(below)
    return out


class _Samples:
    """The samples of one incident direction: directions, weights, pdfs, lobes and which are atoms."""

    def __init__(self, bsdf, wo: np.ndarray, n: int, seed: int):
        from ..distributions.lobes import LobeMixture

        self.wo = wo
        u = np.random.default_rng(seed).random((n, int(bsdf.dim_u)))
        self.wi, self.weight, self.pdf = (np.asarray(a, float) for a in bsdf.sample(wo, u))
        wi_l, self.k = bsdf.sample_lobe(wo, u)
        self.wi_lobe = np.asarray(wi_l, float)
        dist = bsdf.distribution(wo)
        lobes = len(bsdf.LOBES)
        if isinstance(dist, LobeMixture):
            self.p_lobe = np.broadcast_to(dist.probabilities, (lobes,)).astype(float)
            self.delta = np.asarray(dist.delta, bool)
        else:
            self.p_lobe, self.delta = np.ones(1), np.zeros(1, bool)
        self.atom = self.delta[np.asarray(self.k)] if self.delta.any() else np.zeros(n, bool)
        self.valid = ~self.atom & (self.pdf > 0) & np.all(np.isfinite(self.wi), -1)


def _check_sample(bsdf, s: _Samples) -> None:
    n = len(s.wi)
    if s.wi.shape != (n, 3) or s.weight.shape != (n, 3) or s.pdf.shape != (n,):
        raise _fail("sample", f"sample(wo, u (n, {bsdf.dim_u})) returned shapes {s.wi.shape}, {s.weight.shape}, "
                              f"{s.pdf.shape}; expected (n, 3), (n, 3), (n,)")
    bad = ~(np.all(np.isfinite(s.wi), -1) & np.all(np.isfinite(s.weight), -1) & np.isfinite(s.pdf))
    if bad.any():
        raise _fail("sample", f"{int(bad.sum())} of {n} samples at wo = {s.wo.round(3).tolist()} are not finite, "
                              f"e.g. wi {s.wi[bad][0]}, weight {s.weight[bad][0]}, pdf {s.pdf[bad][0]}")
    if np.any(s.weight < 0) or np.any(s.pdf < 0):
        raise _fail("sample", "negative weights or pdfs")
    norm = np.linalg.norm(s.wi, axis=-1)
    if np.any(np.abs(norm - 1) > 1e-5):
        raise _fail("sample", f"directions are not unit vectors (|wi| up to {norm.max():.6g})")
    if not np.allclose(s.wi, s.wi_lobe, rtol=0, atol=1e-6):
        raise _fail("sample", "sample and sample_lobe give other directions for the same uniforms")


def _check_weight(bsdf, s: _Samples) -> None:
    cont = ~s.atom
    wi, wt, p = s.wi[cont], s.weight[cont], s.pdf[cont]
    if len(wi):
        own = np.asarray(bsdf.pdf(s.wo, wi), float)
        if not np.allclose(p, own, rtol=1e-5, atol=1e-12 * max(own.max(initial=0), 1.0)):
            i = int(np.argmax(np.abs(p - own)))
            raise _fail("weight", f"the pdf sample returns is not pdf(wo, wi): {p[i]:.6g} vs {own[i]:.6g} at "
                                  f"wi = {wi[i].round(4).tolist()}")
        ev = np.asarray(bsdf.eval(s.wo, wi), float)
        want = np.where(p[:, None] > 0, ev / np.where(p > 0, p, 1.0)[:, None], 0.0)
        _close("weight", wt, want, s.wo, wi, "eval / pdf")
    for i, name in enumerate(bsdf.LOBES):
        sel = s.atom & (s.k == i)
        if sel.any():
            value = np.asarray(bsdf.delta_value(name, s.wo)[1], float)
            _close("weight", s.weight[sel], np.broadcast_to(value / s.p_lobe[i], s.weight[sel].shape), s.wo,
                   s.wi[sel], f"delta lobe {name!r}: delta_value / P_k")


def _close(check: str, got: np.ndarray, want: np.ndarray, wo, wi, what: str, rtol: float = 1e-5) -> None:
    scale = max(float(np.max(np.abs(want), initial=0)), 1e-30)
    bad = np.abs(got - want) > rtol * np.abs(want) + 1e-9 * scale
    if bad.any():
        r = int(np.argwhere(bad)[0][0])
        raise _fail(check, f"{int(bad.any(-1).sum() if bad.ndim > 1 else bad.sum())} of {len(got)} samples at "
                           f"wo = {np.round(wo, 3).tolist()}: weight {np.round(got[r], 6).tolist()}, {what} = "
                           f"{np.round(want[r], 6).tolist()} (wi = {np.round(wi[r], 4).tolist()})")


def _chart(s: _Samples):
    from .charts import SphereChart

    if not s.valid.any():
        return RotatedChart(SphereChart(power=2.0), np.array([0.0, 0.0, 1.0]))
    return RotatedChart(SphereChart(power=2.0), s.wi[s.valid][np.argmax(s.pdf[s.valid])])


def _chi2_and_mass(bsdf, samples: list[_Samples], z: float, alpha: float) -> tuple[str, str]:
    from .chisquare import cell_integrals, histogram, pooled_chi2, sidak_threshold

    level = sidak_threshold(alpha, len(samples))
    masses = []
    for s in samples:
        n = len(s.wi)
        chart = _chart(s)
        expected = n * cell_integrals(lambda w, s=s: np.asarray(bsdf.pdf(s.wo, w), float), chart, BINS, quad=5,
                                     sub=SUB)
        mass = float(expected.sum()) / n
        counts, off = histogram(chart.to_param(s.wi[s.valid]), BINS) if s.valid.any() else (np.zeros(BINS), 0)
        p_atoms = float(s.p_lobe[s.delta].sum()) if s.delta.any() else 0.0
        obs = np.concatenate([counts.ravel(), [s.atom.sum(), (~s.valid & ~s.atom).sum() + off]])
        # a cell the quadrature sees as empty may hold a sliver of support (as in chi2_gof)
        expected = np.where((expected <= 0) & (counts > 0), 1e-9, expected)
        exp = np.concatenate([expected.ravel(), [n * p_atoms, n * max(0.0, 1.0 - p_atoms - mass)]])
        res = pooled_chi2(obs, exp, 5.0, f"{bsdf!r} at wo = {s.wo.round(3).tolist()}")
        if not res.pvalue >= level:
            raise _fail("chi2", f"the sampled directions do not follow pdf (p = {res.pvalue:.3g} < {level:.3g}):\n"
                                f"{res.message()}")
        masses.append((s, mass))
    for s, mass in masses:
        n, share = len(s.wi), float(s.valid.mean())
        tol = z * np.sqrt(max(share * (1 - share), 1.0 / n) / n) + 0.005
        if abs(mass - share) > tol:
            raise _fail("mass", f"at wo = {s.wo.round(3).tolist()} pdf integrates to {mass:.4f} over the sphere but "
                                f"{share:.4f} of the samples are valid (continuous lobes, pdf > 0); allowed {tol:.4f}")
    return "ok", "ok"


def _check_reciprocity(bsdf) -> str:
    if not getattr(bsdf, "reciprocal", True):
        return "skipped: the model declares reciprocal = False"
    wo, wi = unit_rows(2000, 7), unit_rows(2000, 8)
    a, b = np.asarray(bsdf.f(wo, wi), float), np.asarray(bsdf.f(wi, wo), float)
    scale = max(float(np.abs(a).max(initial=0)), 1e-30)
    bad = np.abs(a - b) > 1e-5 * np.abs(b) + 1e-9 * scale
    if bad.any():
        r = int(np.argwhere(bad)[0][0])
        raise _fail("reciprocity", f"f(wo, wi) = {a[r].round(6).tolist()} but f(wi, wo) = {b[r].round(6).tolist()} "
                                   f"at wo = {wo[r].round(4).tolist()}, wi = {wi[r].round(4).tolist()} "
                                   f"({int(bad.any(-1).sum())} of {len(wo)} pairs); declare reciprocal = False if "
                                   "the model is not")
    return "ok"


def _check_energy(samples: list[_Samples], z: float) -> str:
    for s in samples:
        if s.wo[2] <= 0:
            continue
        mean, se = s.weight.mean(0), s.weight.std(0) / np.sqrt(len(s.weight))
        if np.any(mean > 1 + z * se + 0.002):
            raise _fail("energy", f"at wo = {s.wo.round(3).tolist()} the mean sample weight (the albedo) is "
                                  f"{mean.round(4).tolist()} ± {se.round(4).tolist()} > 1: the BSDF creates energy")
    return "ok"


def _check_mitsuba(bsdf, name: str | None, params: dict, rename: dict | None) -> str:
    why = mitsuba_available()
    if why:
        return why
    if name is None:
        return "skipped: an instance was given (no parameters to build Mitsuba's plugin from)"
    from .mitsuba_bsdf import bsdf_eval_pdf, mitsuba_bsdf

    try:
        spec = mitsuba_spec(name, params, rename)
        theirs = mitsuba_bsdf(spec)
    except NoSpec as exc:
        return f"skipped: {exc}"
    except Exception as exc:  # noqa: BLE001 - Mitsuba's own errors for an unknown plugin or parameter
        if "not found" in str(exc):
            return f"skipped: Mitsuba lacks a plugin ({str(exc).split(': ')[-1]})"
        raise _fail("mitsuba", f"Mitsuba refuses the plugin dict {spec!r}: {exc}") from None
    wo, wi = unit_rows(400, 11, upper=True), unit_rows(400, 12)
    ev_m, p_m = bsdf_eval_pdf(theirs, wo, wi)
    ev, p = np.asarray(bsdf.eval(wo, wi), float), np.asarray(bsdf.pdf(wo, wi), float)
    seen = (ev_m.sum(-1) > 0) & (p_m > 0)
    transmits = bool(np.any(seen & (wi[:, 2] < 0)))
    for what, a, b, rtol, sel in (("eval", ev, ev_m, 2e-3, slice(None)), ("pdf", p, p_m, 5e-3, seen)):
        a, b = a[sel], b[sel]
        tol = rtol * np.abs(b) + 1e-5 * max(float(np.abs(b).max(initial=0)), 1e-3)
        # a transmitting model's Mitsuba pdf leaves out the samples Mitsuba rejects (vrlab's counts them)
        bad = (b - a > tol) if what == "pdf" and transmits else (np.abs(a - b) > tol)
        if bad.any():
            r = int(np.argwhere(bad)[0][0])
            raise _fail("mitsuba", f"{what} differs from Mitsuba's {spec['type']!r} at {int(bad.sum())} of {bad.size} "
                                   f"values, e.g. {np.round(a.ravel()[r], 6)} vs {np.round(b.ravel()[r], 6)}")
    return "ok"


def check_bsdf(name_or_class: Any, *, samples: int = 40_000, z: float = 5.0, level: float = 1e-3,
               mitsuba: bool = True, mitsuba_names: dict | None = None, **params) -> dict[str, str]:
    """Run the common checks (module docstring) on a BSDF; ``AssertionError`` naming the first
    failed check, else ``{check: "ok" | "skipped: why"}``.

    ``name_or_class``: a registered name (``"roughconductor"``), a ``BSDFModel`` subclass (a
    user's own, registered or not) or an instance (then no ``params``); ``params``: its
    constructor's keyword arguments (nested elements as plugin dicts to compare with Mitsuba);
    ``samples`` per incident direction; ``z`` the allowed z-score; ``level`` the family-wise
    level of the chi-square tests; ``mitsuba=False`` skips Mitsuba; ``mitsuba_names`` maps
    vrlab parameter names to Mitsuba's where they differ."""
    from .. import checks
    from ..render.bsdfs import BSDFModel

    n = checks.integer(samples, "samples", low=1000, high=10_000_000)
    z = checks.real(z, "z", low=0, low_open=True)
    level = checks.real(level, "level", low=0, high=1, low_open=True, high_open=True)
    cls, bsdf = build_element("bsdf", name_or_class, params, WHO)
    if not isinstance(bsdf, BSDFModel):
        raise TypeError(f"name_or_class: expected a BSDF (a vrlab.render.bsdfs.BSDFModel), got {bsdf!r}")
    out = {"params": check_params(cls, params, WHO)}
    draws = [_Samples(bsdf, wo, n, seed) for seed, wo in enumerate(_incident(bsdf))]
    for s in draws:
        _check_sample(bsdf, s)
    out["sample"] = "ok"
    for s in draws:
        _check_weight(bsdf, s)
    out["weight"] = "ok"
    out["chi2"], out["mass"] = _chi2_and_mass(bsdf, draws, z, level)
    out["reciprocity"] = _check_reciprocity(bsdf)
    out["energy"] = _check_energy(draws, z)
    name = getattr(cls, "plugin_name", None) if cls is not None else None
    out["mitsuba"] = _check_mitsuba(bsdf, name, params, mitsuba_names) if mitsuba else "skipped: mitsuba=False"
    return out
