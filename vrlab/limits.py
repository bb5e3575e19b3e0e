"""The one table of limits, shared by the library functions and the command line.

A value above a limit is refused with a ``ValueError`` (library) or a usage error (CLI)
naming the argument and the limit; both read the numbers here, so ``vrlab render --spp``
and ``vrlab.render.render(spp=...)`` accept exactly the same values.

==================  ==========  ==============================================================
name                value       what
==================  ==========  ==============================================================
``MAX_SPP``         2^24        samples per pixel of one render (16.7 M: days of work)
``MAX_SIDE``        65536       image width or height in pixels (the scene loader's bound too)
``MAX_PIXELS``      2^26        pixels of one image (67 M)
``MAX_SAMPLES``     1024        emitter / BSDF samples per shading point
``MAX_CANDIDATES``  4096        RIS candidates, and the ``:<int>`` of a lab recipe
``MAX_RADIUS``      256         ReSTIR's neighbour radius in pixels (grid steps)
``MAX_OFFSETS``     2^22        neighbour offsets one ReSTIR radius enumerates ((2r+1)^d)
``MAX_N``           2^30        integrand evaluations of one lab cell
``MAX_REPS``        10^6        repetitions of one lab cell
``max_workers()``   max(256,    worker processes (more only fork without speed-up)
                    4 x CPUs)
==================  ==========  ==============================================================

Scene values (:mod:`vrlab.render.scene_checks` applies them as each element is built, so a
scene file's bad value is refused at load, naming the element, its file and line; the
renderer intersects and shades in float32):

==================  ==========  ==============================================================
``MAX_COORD``       1e8         entries of a ``to_world`` matrix, mesh vertices (absolute)
``SCALE_RANGE``     1e-9, 1e8   scale factors (singular values) of a transform
``MAX_VALUE``       1e15        radiance, intensities and reflectances
``MAX_ALPHA``       1e4         microfacet roughness ``alpha``
``MAX_EXPONENT``    1e6         the Phong ``exponent``
==================  ==========  ==============================================================

Allowed names: ``LIGHT_SELECTIONS`` (``uniform``, ``power``, ``bvh``).

``MAX_SIDE``, ``MAX_PIXELS`` bound a scene's film too, and ``MAX_SAMPLES`` its integrator's
``emitter_samples`` / ``bsdf_samples``: a scene asks no more than ``vrlab render`` accepts.
"""
from __future__ import annotations

import os

MAX_SPP = 1 << 24
MAX_SIDE = 65536
MAX_PIXELS = 1 << 26
MAX_SAMPLES = 1024
MAX_CANDIDATES = 4096
MAX_RADIUS = 256
MAX_OFFSETS = 1 << 22
MAX_N = 1 << 30
MAX_REPS = 10**6
#: the renderer's light selections (``render(light_selection=...)``, ``--light-selection``)
LIGHT_SELECTIONS = ("uniform", "power", "bvh")
MAX_COORD = 1e8
SCALE_RANGE = (1e-9, 1e8)
MAX_VALUE = 1e15
MAX_ALPHA = 1e4
MAX_EXPONENT = 1e6


def max_workers() -> int:
    """The largest worker-process count accepted: max(256, 4 x CPUs of this machine)."""
    return max(256, 4 * (os.cpu_count() or 1))
