"""``check_emitter``: the common checks every emitter element must pass (as
:func:`~vrlab.testing.check_bsdf` for BSDFs).

The emitter protocol is :mod:`vrlab.render.emitters.base`'s: ``sample(ref, u) -> (w, pdf, le,
dist)``, ``pdf(ref, w)`` (solid angle; 0 for a delta light) and ``radiance(ref, w)``.
``check_emitter(name_or_class, **params)`` runs, in order, raising ``AssertionError`` whose
message starts with ``check_emitter[<check>]``:

``params``   bad parameters refused, naming them (:mod:`vrlab.testing.elements`);
``sample``   finite unit directions towards the light, pdf > 0, radiance >= 0, distances > 0,
             in the shapes of the protocol;
``density``  a delta light (``is_delta``): ``pdf`` is 0 in every direction (no density in solid
             angle), ``sample`` returns density 1 (the counting measure) and one direction and
             value per reference point whatever the uniforms, and a light at a point is the same
             point ref + w dist from every reference point;  any other light: the sampled
             directions against ``pdf`` (chi-square with the shipped harness,
             :func:`~vrlab.testing.chi2_gof`, on a sphere chart whose pole is the sample of
             highest density), and ``pdf`` integrating to 1 over the sphere (to 0.005);
``eval``     ``radiance(ref, w)`` at the sampled directions equals the ``le`` that ``sample``
             returned with them;
``mitsuba``  with Mitsuba 3 installed: Mitsuba's emitter of the same name and parameters
             (``sample_direction``, ``eval_direction``, ``pdf_direction`` through its Python API,
             ``scalar_rgb``) at the same reference points: a delta light's direction, distance
             and value; any other light's density and radiance at Mitsuba's sampled directions.

Reference points: (0.3, -0.2, 1.5), (-0.4, 0.6, 2.5) and (0.05, 0.02, 1): in front of a light
at the origin shining along +z (the default frame of ``spot`` and ``projector``).  An ``area``
emitter is sampled by its shape (:class:`vrlab.render.lights.Light`, checked with the shapes);
here only its parameters are.  Returns ``{check: "ok" | "skipped: why"}``.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .elements import NoSpec, RotatedChart, build_element, check_params, mitsuba_available, mitsuba_spec

__all__ = ["check_emitter", "REFERENCE_POINTS"]

WHO = "check_emitter"
REFERENCE_POINTS = np.array([[0.3, -0.2, 1.5], [-0.4, 0.6, 2.5], [0.05, 0.02, 1.0]])


def _fail(check: str, message: str) -> AssertionError:
    return AssertionError(f"{WHO}[{check}]: {message}")


class _FromPoint:
    """An emitter's directions from one reference point as a distribution (``sample(u)``,
    ``pdf(w)``, solid angle) for the chi-square harness."""

    dim_u, dim_x = 2, 3

    def __init__(self, emitter, ref: np.ndarray):
        self.emitter, self.ref = emitter, ref

    def sample(self, u):
        u = np.asarray(u, float)
        return self.emitter.sample(np.broadcast_to(self.ref, (len(u), 3)).copy(), u)[0]

    def pdf(self, w):
        w = np.asarray(w, float)
        flat = w.reshape(-1, 3)
        p = self.emitter.pdf(np.broadcast_to(self.ref, (len(flat), 3)).copy(), flat)
        return np.asarray(p, float).reshape(w.shape[:-1])

    def __repr__(self) -> str:
        return f"{self.emitter!r} from {self.ref.tolist()}"


def _draw(emitter, ref: np.ndarray, u: np.ndarray):
    refs = np.broadcast_to(ref, (len(u), 3)).copy()
    return tuple(np.asarray(a, float) for a in emitter.sample(refs, u))


def _check_sample(emitter, n: int) -> None:
    u = np.random.default_rng(3).random((n, 2))
    for ref in REFERENCE_POINTS:
        w, pdf, le, dist = _draw(emitter, ref, u)
        if w.shape != (n, 3) or pdf.shape != (n,) or le.shape != (n, 3) or dist.shape != (n,):
            raise _fail("sample", f"sample(ref (n, 3), u (n, 2)) returned shapes {w.shape}, {pdf.shape}, {le.shape}, "
                                  f"{dist.shape}; expected (n, 3), (n,), (n, 3), (n,)")
        if not (np.all(np.isfinite(w)) and np.all(np.isfinite(pdf)) and np.all(np.isfinite(le))):
            raise _fail("sample", f"non-finite directions, pdfs or values from {ref.tolist()}")
        if np.any(np.abs(np.linalg.norm(w, axis=-1) - 1) > 1e-5):
            raise _fail("sample", "directions are not unit vectors")
        if np.any(pdf <= 0) or np.any(le < 0) or np.any(~(dist > 0)):
            raise _fail("sample", f"from {ref.tolist()}: pdf must be > 0, radiance >= 0 and distance > 0 (min pdf "
                                  f"{pdf.min():.3g}, min radiance {le.min():.3g}, min distance {dist.min():.3g})")


def _check_delta(emitter) -> str:
    u = np.random.default_rng(4).random((64, 2))
    points = []
    for ref in REFERENCE_POINTS:
        w, pdf, le, dist = _draw(emitter, ref, u)
        if np.any(pdf != 1):
            raise _fail("density", f"a delta light's sample must return density 1 (counting measure), got {pdf[:3]}")
        if np.ptp(w, 0).max() > 1e-9 or np.ptp(le, 0).max() > 1e-9 * max(le.max(), 1.0):
            raise _fail("density", f"a delta light reaches {ref.tolist()} along one direction with one value, but "
                                   "sample returns several for different uniforms")
        p = np.asarray(emitter.pdf(np.broadcast_to(ref, (len(u), 3)).copy(), _sphere(len(u))), float)
        if np.any(p != 0):
            raise _fail("density", f"a delta light has no density in solid angle: pdf must be 0, got {p.max():.3g}")
        if np.isfinite(dist[0]):
            points.append(ref + w[0] * dist[0])
    if points and np.ptp(np.array(points), 0).max() > 1e-6 * max(1.0, np.abs(points).max()):
        raise _fail("density", f"ref + w dist is not one point from every reference point: {np.round(points, 6).tolist()}")
    return "ok (delta)"


def _sphere(n: int) -> np.ndarray:
    v = np.random.default_rng(5).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _check_density(emitter, n: int, level: float) -> str:
    from .charts import SphereChart
    from .chisquare import assert_gof, chi2_gof, integrate

    results = []
    for k, ref in enumerate(REFERENCE_POINTS):
        dist = _FromPoint(emitter, ref)
        w = dist.sample(np.random.default_rng(6).random((512, 2)))
        chart = RotatedChart(SphereChart(power=2.0), w[np.argmax(dist.pdf(w))])
        results.append(chi2_gof(dist, chart, (32, 32), n=n, rng=[7, k], sub=2, name=repr(dist)))
        total = integrate(dist.pdf, chart, 64, quad=6)
        if abs(total - 1) > 0.005:
            raise _fail("density", f"pdf integrates to {total:.4f} over the sphere from {ref.tolist()}, not 1")
    try:
        assert_gof(results, alpha=level)
    except AssertionError as exc:
        raise _fail("density", f"the sampled directions do not follow pdf: {exc}") from None
    return "ok"


def _check_eval(emitter, n: int) -> str:
    u = np.random.default_rng(8).random((n, 2))
    for ref in REFERENCE_POINTS:
        w, _, le, _ = _draw(emitter, ref, u)
        got = np.asarray(emitter.radiance(np.broadcast_to(ref, (n, 3)).copy(), w), float)
        bad = np.abs(got - le) > 1e-5 * np.abs(le) + 1e-9 * max(float(le.max()), 1e-30)
        if bad.any():
            r = int(np.argwhere(bad)[0][0])
            raise _fail("eval", f"radiance(ref, w) = {got[r].round(6).tolist()} but sample returned "
                                f"{le[r].round(6).tolist()} with w = {w[r].round(4).tolist()} from {ref.tolist()}")
    return "ok"


def _mitsuba_samples(spec: dict, m: int):
    """Mitsuba's ``sample_direction`` at every reference point: (d, pdf, dist, weight, eval, pdf_direction)."""
    import mitsuba as mi

    from .mitsuba_bsdf import _variant as variant
    with variant("scalar_rgb"):
        e = mi.load_dict(spec)
        u = np.random.default_rng(9).random((m, 2)).tolist()
        out = []
        for ref in REFERENCE_POINTS:
            it = mi.Interaction3f()
            it.p = mi.Point3f(*ref.tolist())
            for a, b in u:
                ds, weight = e.sample_direction(it, mi.Point2f(a, b))
                out.append((ref, np.array(ds.d), float(ds.pdf), float(ds.dist), np.array(weight),
                            np.array(e.eval_direction(it, ds)), float(e.pdf_direction(it, ds))))
    return out


def _check_mitsuba(emitter, name: str | None, params: dict, rename: dict | None) -> str:
    why = mitsuba_available()
    if why:
        return why
    if name is None:
        return "skipped: an instance was given (no parameters to build Mitsuba's plugin from)"
    if emitter.is_area:
        return "skipped: an area emitter needs its shape (the renders of tests/test_mitsuba_elements.py compare it)"
    try:
        spec = mitsuba_spec(name, params, rename)
        rows = _mitsuba_samples(spec, 32)
    except NoSpec as exc:
        return f"skipped: {exc}"
    except Exception as exc:  # noqa: BLE001 - Mitsuba's own errors
        if "not found" in str(exc):
            return f"skipped: Mitsuba lacks a plugin ({str(exc).split(': ')[-1]})"
        raise _fail("mitsuba", f"Mitsuba refuses the plugin dict {spec!r}: {exc}") from None
    for ref, d, pdf, dist, weight, value, _ in rows:
        refs = ref[None, :]
        if emitter.is_delta:
            w, _, le, dst = (np.asarray(a, float)[0] for a in emitter.sample(refs, np.full((1, 2), 0.5)))
            pairs = (("direction", w, d, 1e-5), ("value", le, weight, 2e-3),
                     ("distance", np.array([dst]), np.array([dist]), 1e-4 if np.isfinite(dst) else np.inf))
        else:
            p = float(np.asarray(emitter.pdf(refs, d[None, :]), float)[0])
            le = np.asarray(emitter.radiance(refs, d[None, :]), float)[0]
            pairs = (("pdf", np.array([p]), np.array([pdf]), 2e-3), ("radiance", le, value, 2e-3))
        for what, a, b, rtol in pairs:
            if np.isinf(rtol):
                continue
            if np.any(np.abs(a - b) > rtol * np.abs(b) + 1e-6 * max(float(np.abs(b).max()), 1e-3)):
                raise _fail("mitsuba", f"{what} from {ref.tolist()} along {np.round(d, 4).tolist()}: "
                                       f"{np.round(a, 6).tolist()} vs Mitsuba's {np.round(b, 6).tolist()}")
    return "ok"


def check_emitter(name_or_class: Any, *, samples: int = 40_000, level: float = 1e-3, mitsuba: bool = True,
                  mitsuba_names: dict | None = None, **params) -> dict[str, str]:
    """Run the common checks (module docstring) on an emitter; ``AssertionError`` naming the first
    failed check, else ``{check: "ok" | "skipped: why"}``.  Arguments as
    :func:`~vrlab.testing.check_bsdf`'s (``samples`` per reference point for the chi-square)."""
    from .. import checks
    from ..render.emitters import Emitter

    n = checks.integer(samples, "samples", low=1000, high=10_000_000)
    level = checks.real(level, "level", low=0, high=1, low_open=True, high_open=True)
    cls, emitter = build_element("emitter", name_or_class, params, WHO)
    if not isinstance(emitter, Emitter):
        raise TypeError(f"name_or_class: expected an emitter (a vrlab.render.emitters.Emitter), got {emitter!r}")
    out = {"params": check_params(cls, params, WHO)}
    if emitter.is_area:
        why = "skipped: an area emitter is sampled by its shape (vrlab.render.lights.Light)"
        out.update(sample=why, density=why, eval=why)
    else:
        _check_sample(emitter, 256)
        out["sample"] = "ok"
        out["density"] = _check_delta(emitter) if emitter.is_delta else _check_density(emitter, n, level)
        out["eval"] = _check_eval(emitter, 256)
    name = getattr(cls, "plugin_name", None) if cls is not None else None
    out["mitsuba"] = _check_mitsuba(emitter, name, params, mitsuba_names) if mitsuba else "skipped: mitsuba=False"
    return out
