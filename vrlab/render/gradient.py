"""Gradient-domain rendering: the primal image and its finite differences by common random
numbers, then a screened Poisson reconstruction (lecture 000, Moon, CT5202, "Common Random
Numbers"; Lehtinen et al. 2013, Kettunen et al. 2015 for the idea in path space).

For every pixel x and every sample with primary-sample uniforms u, the pixel integrand
(:class:`~vrlab.render.pixels.PixelIntegrand`) is evaluated at x, at its right neighbour
x + (1, 0) and at its lower neighbour x + (0, 1), all with the *same* u moved by one pixel
(the lecture's CRN shift: the same sub-pixel position, light choice and directions).  Then

    primal  = mean_u I(x; u)                         (MonteCarlo on the pixel integrand)
    dx[y, x] = mean_u [I(x + 1, y; u) - I(x, y; u)]   (CRNDifference, shape (H, W - 1, 3))
    dy[y, x] = mean_u [I(x, y + 1; u) - I(x, y; u)]   (CRNDifference, shape (H - 1, W, 3))

each with its per-pixel standard error from the sample differences, so

    Var[a - b] = Var[a] + Var[b] - 2 Cov[a, b]

is what the gradients' error bars measure; where neighbours see the same surface and
light the covariance is large and the gradient nearly noise-free.  ``common=False`` gives
the neighbour independent uniforms (Cov = 0), the baseline.  A sample costs three
evaluations of the pixel integrand (the base one is shared by the primal and both
differences).  :func:`~vrlab.render.screened_poisson` then solves for the image.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .. import checks
from .._rng import RNGLike
from ..estimate import Estimate
from .cost import Cost
from .film import _Job, as_plan, build_job, execute
from .planning import RenderPlan
from .scene import Scene

__all__ = ["GradientDomainImage", "render_gradient_domain"]


@dataclass
class GradientDomainImage:
    """The three estimates of a gradient-domain render (see the module docstring)."""

    primal: Estimate
    dx: Estimate
    dy: Estimate

    def reconstruct(self, alpha: float = 0.2, norm: str = "l2", **options: Any) -> np.ndarray:
        """The screened Poisson reconstruction ``(H, W, 3)`` (:func:`~vrlab.render.screened_poisson`)."""
        from .poisson import screened_poisson

        return screened_poisson(self.primal, self.dx, self.dy, alpha=alpha, norm=norm, **options)


class _GradientJob(_Job):
    """Units of primal, dx and dy statistics (the base pixel's values are shared)."""

    estimates = ("primal", "dx", "dy")
    common = True

    def block(self, pixels: np.ndarray, u: np.ndarray, gen: np.random.Generator, cost: Cost) -> tuple:
        from ..estimators import CRNDifference, MonteCarlo

        integ = self.integrand
        base = integ.integrand(pixels, cost=cost)
        mc, crn = MonteCarlo(), CRNDifference(common=self.common)
        out = [mc.accumulate(mc.unit_outputs(base, u))]
        for shift in ((0, 1), (1, 0)):                   # right neighbour (dx), lower neighbour (dy)
            other = integ.integrand(pixels, shift, cost)
            if self.common:
                pts = u
            else:                                        # the neighbour's own uniforms, then the base's
                pts = np.concatenate([self.samplers[u.shape[1]].draw(len(pixels), gen), u], -1)
            out.append(crn.accumulate(crn.unit_outputs((other, base), pts)))
        return tuple(out)

    def summarize(self, i: int, stats) -> tuple[np.ndarray, np.ndarray]:
        from ..estimators import MonteCarlo

        value, stderr = MonteCarlo().summarize(stats)
        return np.moveaxis(np.asarray(value), 0, -1), np.moveaxis(np.asarray(stderr), 0, -1)


def render_gradient_domain(scene: Scene | RenderPlan | str | os.PathLike, spp: int | None = None,
                           estimator: Any = "mis-power", *, points: Any = None, rng: RNGLike = None,
                           workers: int | None = 1, executor: Any = None, common: bool = True,
                           units: int | None = None, light_selection: str = "uniform",
                           emitter_samples: int | None = None, bsdf_samples: int | None = None,
                           ris_candidates: int = 8, chunk_pixels: int | None = None,
                           progress: Callable[[int, int], None] | None = None, width: int | None = None,
                           height: int | None = None, spp_batch: int | None = None, checkpoint: Any = None,
                           kernels: str = "auto") -> GradientDomainImage:
    """Render the primal image and its CRN gradients: a :class:`GradientDomainImage` with
    ``.primal`` (H, W, 3), ``.dx`` (H, W - 1, 3) = I(x + 1, y) - I(x, y) and ``.dy``
    (H - 1, W, 3), each a :class:`~vrlab.Estimate` with a per-pixel ``stderr``, and
    ``.reconstruct(alpha, norm)``.

    ``common``: the neighbour's sample uses the same uniforms as the pixel's (True, CRN)
    or independent ones (False).  The other arguments are :func:`~vrlab.render.render`'s
    (``scene`` may be a :class:`~vrlab.render.RenderPlan`);
    the image depends on the seed only, as there (``spp_batch``, ``checkpoint`` too).  ``dx.extra`` / ``dy.extra`` hold
    ``common``.  The gradients' stderr is valid for i.i.d. ``points`` only.
    """
    t0 = time.perf_counter()
    common = checks.flag(common, "common")
    plan = as_plan(scene, dict(spp=spp, estimator=estimator, points=points, units=units,
                               light_selection=light_selection, emitter_samples=emitter_samples,
                               bsdf_samples=bsdf_samples, ris_candidates=ris_candidates, chunk_pixels=chunk_pixels,
                               width=width, height=height, spp_batch=spp_batch, workers=workers, kernels=kernels))
    if plan.spp < 2:
        raise ValueError(f"spp: gradient-domain rendering needs spp >= 2 (a standard error per pixel), got {plan.spp}")
    job, sampler = build_job(plan, rng, _GradientJob, cost=3)
    job.common = common
    cost = Cost()
    (p, pe), (dx, dxe), (dy, dye) = execute(job, plan.workers, executor, progress, checkpoint, cost=cost)
    seconds = time.perf_counter() - t0
    spp, integ = job.spp, job.integrand
    label = integ.estimator.label
    evals = integ.units * int(integ.estimator.evals_per_unit)
    # the whole render's counted cost (a sample: three pixel evaluations), in each estimate
    extra = {"common": common, "points": sampler.label, "kernels": plan.kernels, "cost": cost.report()}

    def estimate(value, stderr, method, n_evals):
        return Estimate(value, stderr, spp, n_evals, seconds, stderr.astype(np.float64) ** 2 * spp, method,
                        {**extra, "cost": dict(extra["cost"])})

    return GradientDomainImage(
        primal=estimate(p, pe, label, spp * evals),
        dx=estimate(dx[:, :-1], dxe[:, :-1], f"CRNDifference[{label}]", 2 * spp * evals),
        dy=estimate(dy[:-1], dye[:-1], f"CRNDifference[{label}]", 2 * spp * evals))
