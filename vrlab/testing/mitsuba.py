"""Mitsuba 3 as the renderer's oracle: :func:`mitsuba_reference` (per-pixel mean and per-sample
variance from Mitsuba's ``moment`` integrator, in CIE XYZ), :func:`render_test` (Mitsuba 3's own
render-regression criterion, src/render/tests/test_renders.py), :func:`mean_z_test` (channel
means) and :func:`assert_agrees_with_mitsuba` (vrlab vs Mitsuba on an XML scene, both tests).
Importing this module does not import Mitsuba; the functions that render do.
"""
from __future__ import annotations

import dataclasses
import os
import re
import time
import xml.etree.ElementTree as ET
from typing import Any, NamedTuple

import numpy as np

from ..colour import LUMINANCE

from .. import checks
from .mitsuba_scene import REFERENCE_BATCH_SPP, _scene_xml, mitsuba_reference  # noqa: F401

__all__ = ["SRGB_TO_XYZ", "DEFAULT_SAMPLES", "REFERENCE_FACTOR", "MEAN_Z_THRESHOLD", "RenderTestResult",
           "MeanTestResult", "WorstEntry", "Agreement", "rgb_to_xyz", "xyz_stderr_bound", "mitsuba_reference",
           "render_test", "mean_z_test", "sample_budget", "assert_agrees_with_mitsuba"]

#: Linear sRGB (D65) -> CIE XYZ, Mitsuba 3 convention (``srgb_to_xyz``, include/mitsuba/core/spectrum.h).
SRGB_TO_XYZ = np.array([[0.412453, 0.357580, 0.180423],
                        LUMINANCE,
                        [0.019334, 0.119193, 0.950227]])
#: Default samples per image (W x H x spp) of the image under test: Mitsuba's own budget
#: (``sample_budget = int(2e6)`` in test_renders.py).  Measured on this 2-core machine (32x24,
#: direct lighting, CPU seconds per 10^6 samples): vrlab (workers=1) 0.43-0.62, Mitsuba
#: ``scalar_rgb`` with ``moment`` 0.44-0.51 (2 threads); so one check (2e6 + 4 x 2e6 samples)
#: takes 3-5 s on an idle machine, 9-10 s at load 5.
DEFAULT_SAMPLES = 2_000_000
#: The reference gets this many times the samples per pixel of the image under test.  Mitsuba's
#: z ignores the reference's own noise: for a correct renderer whose per-sample variance is the
#: reference's, z ~ N(0, 1 + 1/k), so k = 4 inflates |z| by 1.12 and a pixel fails the Sidak
#: threshold (4.36 at 768 pixels) with probability 1e-4 instead of 1e-5.  The channels of a
#: pixel are strongly correlated, so failures come in threes and 0.25 % of 768 x 3 allows one
#: failing pixel: P(2 or more) = 0.003 with k = 4, but ~0.5 with k = 1 (|z| inflated by 1.41).
REFERENCE_FACTOR = 4
#: |z| bound of :func:`mean_z_test`: two-sided tail 6.3e-5 per channel, 1.9e-4 for 3 channels.
MEAN_Z_THRESHOLD = 4.0
ENV_SAMPLES = "VRLAB_RENDER_TEST_SAMPLES"


def rgb_to_xyz(rgb: Any) -> np.ndarray:
    """``rgb`` (..., 3) linear sRGB as CIE XYZ: ``xyz = SRGB_TO_XYZ @ rgb`` per pixel (float64),
    Mitsuba 3's ``srgb_to_xyz`` (the colour space of its ``moment`` integrator's AOVs)."""
    a = checks.finite_array(rgb, "rgb", last=3)
    return a @ SRGB_TO_XYZ.T


def xyz_stderr_bound(rgb_stderr: Any) -> np.ndarray:
    """Upper bound on the XYZ standard errors from per-channel RGB ones (..., 3):
    sd(sum_j M_ij R_j) <= sum_j M_ij sd(R_j) (Minkowski; equality for fully correlated
    channels, as when the three channels share every random decision; M = SRGB_TO_XYZ >= 0)."""
    a = checks.finite_array(rgb_stderr, "rgb_stderr", last=3)
    if (a < 0).any():
        raise ValueError("rgb_stderr: standard errors must be >= 0")
    return a @ SRGB_TO_XYZ.T


# ----------------------------------------------------------------------------- the tests
class WorstEntry(NamedTuple):
    """One pixel-channel of a :class:`RenderTestResult`: position, z, p-value and values."""
    row: int
    col: int
    channel: int
    z: float
    p_value: float
    image: float
    reference: float


@dataclasses.dataclass(frozen=True)
class RenderTestResult:
    """Outcome of :func:`render_test`: ``passed`` iff ``fraction >= required``."""
    passed: bool
    fraction: float          # passing pixel-channels / all pixel-channels
    required: float          # pass_fraction
    alpha: float             # family-wise significance level
    alpha_sidak: float       # per-test level 1 - (1 - alpha)^(1 / pixels)
    z_threshold: float       # |z| below which a pixel-channel passes (p > alpha_sidak)
    n_entries: int           # pixel-channels tested
    n_failed: int
    spp: int
    worst: tuple             # WorstEntry, largest |z| first
    z: np.ndarray = dataclasses.field(repr=False)

    def __str__(self) -> str:
        worst = "; ".join(f"({w.row}, {w.col}, {w.channel}) z={w.z:.3g} p={w.p_value:.2g} image={w.image:.5g} "
                          f"ref={w.reference:.5g}" for w in self.worst[:3])
        return (f"render test {'passed' if self.passed else 'FAILED'}: {100 * self.fraction:.2f} % of "
                f"{self.n_entries} pixel-channels pass (need {100 * self.required:.2f} %; {self.n_failed} with "
                f"p <= {self.alpha_sidak:.3g}, i.e. |z| >= {self.z_threshold:.3f}; alpha {self.alpha:g}, "
                f"{self.spp} spp); worst: {worst}")


@dataclasses.dataclass(frozen=True)
class MeanTestResult:
    """Outcome of :func:`mean_z_test`, per channel: ``passed`` iff every ``|z| < threshold``."""
    passed: bool
    difference: np.ndarray   # image channel means - reference channel means
    stderr: np.ndarray       # combined standard error of the difference
    z: np.ndarray
    reference: np.ndarray    # reference channel means
    threshold: float

    def __str__(self) -> str:
        rel = self.difference / np.where(self.reference == 0, 1.0, np.abs(self.reference))
        return (f"mean test {'passed' if self.passed else 'FAILED'}: channel means differ by "
                f"{np.array2string(rel * 100, precision=3)} %, z = {np.array2string(self.z, precision=2)} "
                f"(|z| must be < {self.threshold:g})")


def _same_shape(arrays: dict[str, Any]) -> list[np.ndarray]:
    out = [checks.finite_array(v, k, ndim=3) for k, v in arrays.items()]
    if len({a.shape for a in out}) != 1:
        raise ValueError(f"{', '.join(arrays)} must have one (H, W, C) shape, got {[a.shape for a in out]}")
    return out


def _ratio(num: np.ndarray, sd: np.ndarray) -> np.ndarray:
    """|num| / sd, with 0/0 = 0 and x/0 = inf."""
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.abs(num) / sd
    return np.where(sd > 0, z, np.where(num == 0, 0.0, np.inf))


def render_test(image: Any, ref_mean: Any, ref_var: Any, spp: int, *, alpha: float = 0.01,
                pass_fraction: float = 0.9975, var_floor: float = 1e-4) -> RenderTestResult:
    """Mitsuba 3's render-test criterion on ``image`` (H, W, C), rendered with ``spp`` samples
    per pixel, against a reference mean and per-sample variance (:func:`mitsuba_reference`).

    Per pixel-channel: ``z = |image - ref_mean| sqrt(spp / max(ref_var, var_floor))`` and the
    two-sided p-value ``p = 2 (1 - Phi(z))``; with the Sidak per-test level
    ``alpha_s = 1 - (1 - alpha)^(1 / (H W))`` (over pixels, not pixel-channels, as in Mitsuba) a
    pixel-channel passes if ``p > alpha_s``, and the image passes if at least ``pass_fraction``
    of its pixel-channels do.  Mitsuba 3 convention: ``z_test`` and ``test_render`` in
    src/render/tests/test_renders.py (alpha = 0.01, 0.9975, floor 1e-4, 2e6 samples per image,
    XYZ colour).  The reference's own noise is ignored: give it many more samples.
    """
    image, ref_mean, ref_var = _same_shape({"image": image, "ref_mean": ref_mean, "ref_var": ref_var})
    if (ref_var < 0).any():
        raise ValueError("ref_var: per-sample variances must be >= 0")
    spp = checks.integer(spp, "spp", low=1)
    alpha = checks.real(alpha, "alpha", low=0, high=1, low_open=True, high_open=True)
    pass_fraction = checks.real(pass_fraction, "pass_fraction", low=0, high=1)
    var_floor = checks.real(var_floor, "var_floor", low=0)
    from scipy import special
    z = _ratio(image - ref_mean, np.sqrt(np.maximum(ref_var, var_floor) / spp))
    p = special.erfc(z / np.sqrt(2.0))
    alpha_s = -np.expm1(np.log1p(-alpha) / (image.shape[0] * image.shape[1]))
    ok = p > alpha_s
    n_ok = int(ok.sum())
    k = min(5, z.size)
    order = np.argpartition(-z.ravel(), k - 1)[:k]
    order = order[np.argsort(-z.ravel()[order], kind="stable")]
    worst = tuple(WorstEntry(*(int(i) for i in np.unravel_index(j, z.shape)), float(z.flat[j]),
                             float(p.flat[j]), float(image.flat[j]), float(ref_mean.flat[j])) for j in order)
    return RenderTestResult(passed=n_ok >= pass_fraction * z.size, fraction=n_ok / z.size, required=pass_fraction,
                            alpha=alpha, alpha_sidak=float(alpha_s), z_threshold=float(-special.ndtri(alpha_s / 2)),
                            n_entries=z.size, n_failed=z.size - n_ok, spp=spp, worst=worst, z=z)


def mean_z_test(image: Any, stderr: Any, reference: Any, reference_stderr: Any, *,
                threshold: float = MEAN_Z_THRESHOLD) -> MeanTestResult:
    """Channel means of ``image`` and ``reference`` (H, W, C) with per-pixel standard errors:
    per channel c, ``d_c = mean_p image - mean_p reference`` over the P = H W pixels,
    ``se_c = sqrt(sum_p stderr^2 + sum_p reference_stderr^2) / P`` (pixels independent), and
    ``z_c = d_c / se_c``; passes iff every ``|z_c| < threshold`` (default 4: a two-sided normal
    tail of 6.3e-5 per channel).  A 3 % change of a whole image fails it long before the
    per-pixel :func:`render_test` notices.
    """
    image, stderr, reference, reference_stderr = _same_shape(
        {"image": image, "stderr": stderr, "reference": reference, "reference_stderr": reference_stderr})
    for name, a in (("stderr", stderr), ("reference_stderr", reference_stderr)):
        if (a < 0).any():
            raise ValueError(f"{name}: standard errors must be >= 0")
    threshold = checks.real(threshold, "threshold", low=0, low_open=True)
    n = image.shape[0] * image.shape[1]
    diff = (image - reference).reshape(n, -1).mean(0)
    se = np.sqrt((stderr ** 2).reshape(n, -1).sum(0) + (reference_stderr ** 2).reshape(n, -1).sum(0)) / n
    z = np.copysign(_ratio(diff, se), diff)
    return MeanTestResult(passed=bool(np.all(np.abs(z) < threshold)), difference=diff, stderr=se, z=z,
                          reference=reference.reshape(n, -1).mean(0), threshold=threshold)


# ----------------------------------------------------------------------------- vrlab vs Mitsuba
@dataclasses.dataclass(frozen=True)
class Agreement:
    """What :func:`assert_agrees_with_mitsuba` measured (also the text of its ``AssertionError``)."""
    render_test: RenderTestResult
    mean_test: MeanTestResult
    spp: int
    reference_spp: int
    pixels: int
    vrlab_seconds: float
    mitsuba_seconds: float   # 0 for a reference given by the caller
    #: ``(mean, var, reference_spp)`` of the reference used (XYZ), to reuse it for a changed scene
    reference: tuple = dataclasses.field(default=None, repr=False)

    @property
    def passed(self) -> bool:
        """Both tests passed."""
        return self.render_test.passed and self.mean_test.passed

    def __str__(self) -> str:
        return (f"vrlab ({self.spp} spp, {self.vrlab_seconds:.2f} s) vs Mitsuba ({self.reference_spp} spp, "
                f"{self.mitsuba_seconds:.2f} s), {self.pixels} pixels, in XYZ:\n  {self.render_test}\n"
                f"  {self.mean_test}")


def sample_budget(samples: int | None = None) -> int:
    """Samples per image (W x H x spp) of the image under test: ``samples`` if given, else the
    environment variable ``VRLAB_RENDER_TEST_SAMPLES`` (an integer such as ``300000`` or
    ``3e5``) if set, else :data:`DEFAULT_SAMPLES`."""
    if samples is not None:
        return checks.integer(samples, "samples", low=1)
    text = os.environ.get(ENV_SAMPLES, "").strip()
    if not text:
        return DEFAULT_SAMPLES
    value = float(text) if re.fullmatch(r"\d+(\.\d*)?([eE]\+?\d+)?", text) else 0.0
    if not (1 <= value < 1e15 and value == int(value)):
        raise ValueError(f"{ENV_SAMPLES} must be a positive integer number of samples, got {text!r}")
    return int(value)


def assert_agrees_with_mitsuba(scene: Any, *, samples: int | None = None, reference_factor: int = REFERENCE_FACTOR,
                               estimator: Any = "mis-power", rng: Any = 0, seed: int = 0,
                               variant: str = "scalar_rgb", base: Any = None, params: dict | None = None,
                               reference: tuple | None = None, workers: int = 1, alpha: float = 0.01,
                               pass_fraction: float = 0.9975, var_floor: float = 1e-4,
                               mean_threshold: float = MEAN_Z_THRESHOLD, light_selection: str = "uniform"
                               ) -> Agreement:
    """Render ``scene`` (file path, built-in name or XML string) with vrlab's ``render`` and
    compare with Mitsuba 3; ``AssertionError`` with the numbers unless both tests pass.

    vrlab renders ``spp = max(1, samples // (W H))`` samples per pixel (``samples``: see
    :func:`sample_budget`, default :data:`DEFAULT_SAMPLES` = Mitsuba's 2e6) with ``estimator``,
    ``rng`` and ``light_selection`` (``"uniform"``, ``"power"`` or ``"bvh"``); its RGB image goes to XYZ by :func:`rgb_to_xyz`.  Mitsuba renders the
    reference (:func:`mitsuba_reference`, ``seed``, ``variant``) with ``reference_factor`` times
    as many samples per pixel (see :data:`REFERENCE_FACTOR`), unless ``reference = (mean,
    var, reference_spp)`` is given (XYZ, as returned by :func:`mitsuba_reference`; e.g. the
    reference of an unmodified scene, to check that a modified one fails).  Then

    * :func:`render_test` (Mitsuba's criterion, ``alpha``, ``pass_fraction``, ``var_floor``);
    * :func:`mean_z_test` with vrlab's standard errors bounded by :func:`xyz_stderr_bound` and
      the reference's ``sqrt(var / reference_spp)``, ``|z| < mean_threshold``.

    ``params`` override the scene's ``<default>`` values in both renderers; relative file
    names resolve against ``base`` or the scene file's folder.  Returns the :class:`Agreement`.
    """
    from ..render import load_scene, render
    root, _ = _scene_xml(scene, base)
    xml = ET.tostring(root, encoding="unicode")
    vscene = load_scene(xml, params)
    h, w = vscene.sensor.height, vscene.sensor.width
    spp = max(1, sample_budget(samples) // (h * w))
    reference_factor = checks.integer(reference_factor, "reference_factor", low=1)
    t0 = time.perf_counter()
    if reference is None:
        ref_spp = spp * reference_factor
        ref_mean, ref_var = mitsuba_reference(xml, ref_spp, seed=seed, variant=variant, params=params)
    else:
        if not isinstance(reference, (tuple, list)) or len(reference) != 3:
            raise TypeError(f"reference must be (mean, var, reference_spp), got {checks.describe(reference)}")
        ref_mean, ref_var = _same_shape({"reference[0]": reference[0], "reference[1]": reference[1]})
        ref_spp = checks.integer(reference[2], "reference[2]", low=1)
        if ref_mean.shape != (h, w, 3):
            raise ValueError(f"reference: the scene's image is {(h, w, 3)}, the reference {ref_mean.shape}")
    t1 = time.perf_counter()
    est = render(vscene, spp, estimator, rng=rng, workers=workers, light_selection=light_selection)
    t2 = time.perf_counter()
    value, stderr = np.asarray(est.value, np.float64), np.asarray(est.stderr, np.float64)
    bad = ~(np.isfinite(value) & np.isfinite(stderr))
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise AssertionError(f"vrlab's image has {int(bad.sum())} non-finite entries, the first at {where}")
    image = rgb_to_xyz(value)
    rt = render_test(image, ref_mean, ref_var, spp, alpha=alpha, pass_fraction=pass_fraction, var_floor=var_floor)
    mt = mean_z_test(image, xyz_stderr_bound(stderr), ref_mean, np.sqrt(ref_var / ref_spp),
                     threshold=mean_threshold)
    out = Agreement(rt, mt, spp, ref_spp, h * w, t2 - t1, (t1 - t0) if reference is None else 0.0,
                    (ref_mean, ref_var, ref_spp))
    if not out.passed:
        raise AssertionError(str(out))
    return out
