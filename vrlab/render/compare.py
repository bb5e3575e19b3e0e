"""Strategy comparisons: the Veach figure (BSDF sampling | light sampling | MIS).

``compare(scene, strategies, spp)`` renders the scene once per strategy with the same
seed and reports each image's relMSE against a reference: the ``reference`` image if
one is given, else a high-spp ``mis-power`` render (``ref_spp``), which is independent
of the compared images (its own seed).  ``compare_figure`` draws the panels with the
relMSE under each.  Equal spp by default; with ``equal_time=True`` each strategy first
renders a pilot (spp/4 samples) to measure its cost per sample, then gets the spp that
fit in the time the *last* strategy (MIS in the Veach order) needs for ``spp``: the
comparison that counts, error at equal cost (Veach 1997, ch. 9).

Checked before any rendering: ``strategies`` a non-empty list of distinct strategy
names (the presets, :data:`vrlab.render.PRESETS`), ``spp``/``ref_spp`` integers >= 1,
``rng`` an integer >= 0, ``reference`` a finite image of the scene's shape,
``equal_time`` a bool; ``compare_figure`` checks the result dict, the path (suffix and
folder) and ``exposure``.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Sequence

import numpy as np

from .. import checks
from .film import _as_scene, render
from .image import _image, rel_mse, srgb_encode
from .presets import PRESETS
from .scene import Scene

VEACH_STRATEGIES = ("bsdf", "light", "mis-power")


def compare(scene: Scene, strategies: Sequence[str] = VEACH_STRATEGIES, spp: int = 16, *, rng: int = 0,
            reference: np.ndarray | None = None, ref_spp: int = 256, equal_time: bool = False) -> dict:
    """Render ``scene`` with each strategy; ``{"images", "seconds", "rel_mse", "reference",
    "spp"}`` where ``spp`` is an int (equal spp) or a dict per strategy (equal time).
    ``scene`` may be a path or a built-in name (as for ``render``)."""
    scene = _as_scene(scene)
    if isinstance(strategies, str) or not isinstance(strategies, Sequence):
        raise TypeError(f"strategies must be a list of strategy names, got {type(strategies).__name__}")
    strategies = [checks.choice(s, f"strategies[{k}]", PRESETS) for k, s in enumerate(strategies)]
    if not strategies:
        raise ValueError(f"strategies: need at least one of {', '.join(PRESETS)}")
    if len(set(strategies)) != len(strategies):
        raise ValueError(f"strategies: each strategy at most once, got {strategies}")
    spp = checks.integer(spp, "spp", low=1)
    ref_spp = checks.integer(ref_spp, "ref_spp", low=1)
    rng = checks.integer(rng, "rng", low=0)
    equal_time = checks.flag(equal_time, "equal_time")
    if reference is not None:
        reference = _image(reference, "reference", True)
        want = (scene.sensor.height, scene.sensor.width, 3)
        if reference.shape != want:
            raise ValueError(f"reference: shape {reference.shape} differs from the scene's image {want}")
    if reference is None:
        reference = render(scene, ref_spp, "mis-power", rng=np.random.SeedSequence([rng, 1])).value
    counts = {s: spp for s in strategies}
    if equal_time:
        pilot = max(1, spp // 4)
        cost = {}
        for s in strategies:
            t0 = time.perf_counter()
            render(scene, pilot, s, rng=np.random.SeedSequence([rng, 2]))
            cost[s] = (time.perf_counter() - t0) / pilot
        budget = spp * cost[strategies[-1]]
        counts = {s: max(1, int(round(budget / cost[s]))) for s in strategies}
        counts[strategies[-1]] = spp
    images, seconds, errors = {}, {}, {}
    for s in strategies:
        t0 = time.perf_counter()
        images[s] = render(scene, counts[s], s, rng=np.random.SeedSequence([rng, 0])).value
        seconds[s] = time.perf_counter() - t0
        errors[s] = rel_mse(images[s], reference)
    return {"images": images, "seconds": seconds, "rel_mse": errors, "reference": reference,
            "spp": counts if equal_time else spp}


def compare_figure(result: dict, path: str | Path, *, title: str = "", exposure: float = 1.0) -> Path:
    """Panels side by side with relMSE and time under each (matplotlib, Agg); ``path``'s
    suffix picks the format (.png, .pdf, .svg, ...)."""
    keys = ("images", "seconds", "rel_mse", "reference", "spp")
    if not isinstance(result, dict) or any(k not in result for k in keys) or not result["images"]:
        raise ValueError(f"result must be the dict returned by compare() (keys {', '.join(keys)})")
    if not isinstance(path, (str, Path)):
        raise TypeError(f"path must be a file path, got {type(path).__name__}")
    path = Path(path)
    if path.suffix.lower().lstrip(".") not in ("png", "pdf", "svg", "jpg", "jpeg", "eps", "ps", "tif", "tiff", "webp"):
        raise ValueError(f"path: unknown figure format {path.suffix!r}; use .png, .pdf or .svg")
    if not path.parent.is_dir():
        raise ValueError(f"path: the folder {str(path.parent)!r} does not exist")
    exposure = checks.real(exposure, "exposure", low=0, low_open=True)
    if not isinstance(title, str):
        raise TypeError(f"title must be a string, got {type(title).__name__}")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    names = list(result["images"])
    h, w, _ = result["reference"].shape
    fig = Figure(figsize=(3.2 * len(names), 3.2 * h / w + 1.2))
    FigureCanvasAgg(fig)
    for k, name in enumerate(names):
        ax = fig.add_subplot(1, len(names), k + 1)
        ax.imshow(srgb_encode(np.nan_to_num(result["images"][name]) * exposure))
        ax.set_xticks([]), ax.set_yticks([])
        each = f", {result['spp'][name]} spp" if isinstance(result["spp"], dict) else ""
        ax.set_xlabel(f"{name}\nrelMSE = {result['rel_mse'][name]:.3g}, {result['seconds'][name]:.1f} s{each}",
                      fontsize=9)
    equal = "equal time" if isinstance(result["spp"], dict) else f"{result['spp']} spp per strategy"
    fig.suptitle(title or equal, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return Path(path)
