"""The base of texture elements, the surface points they are evaluated at, and constant colours.

A texture maps surface points to colours, vectorised over a batch (Mitsuba 3's
``Texture``, include/mitsuba/render/texture.h):

* ``eval(si) -> (N, 3)``: the linear RGB value (Mitsuba's ``Texture::eval`` in the RGB
  variants);
* ``eval_1(si) -> (N,)``: the scalar value (``Texture::eval_1``).  Mitsuba's rule depends on
  the texture: a constant RGB colour (``srgb``) gives the mean of its channels,
  (R + G + B) / 3; an RGB ``bitmap`` gives the luminance
  Y = 0.212671 R + 0.715160 G + 0.072169 B (``luminance``, include/mitsuba/core/spectrum.h);
  a grey bitmap or a one-channel mesh attribute gives its value; ``checkerboard`` gives its
  colours' ``eval_1``;
* ``mean() -> (3,)``: the average of ``eval`` over the uv square [0, 1]^2 per channel (for
  a bitmap, the mean of its texels), and ``mean_1() -> float``: Mitsuba's scalar
  ``Texture::mean()`` (the luminance of ``mean()`` for an RGB bitmap, the channel mean
  for a constant colour, the mean of the colours' ``mean_1`` for a checkerboard);
* ``is_constant``: whether the value is the same everywhere.

``si`` is a :class:`SurfacePoints` (or a bare ``(N, 2)`` array of uv coordinates).
"""
from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from ... import checks
from ...colour import LUMINANCE  # noqa: F401  (the one definition, re-exported)
from ..registry import Element

__all__ = ["LUMINANCE", "ConstantTexture", "SurfacePoints", "Texture", "apply_uv", "as_texture",
           "surface_points", "take", "uv_transform"]


class SurfacePoints(NamedTuple):
    """A batch of N surface points, as a texture reads them (Mitsuba's ``SurfaceInteraction3f``).

    * ``uv`` ``(N, 2)``: texture coordinates;
    * ``prim`` ``(N,)`` int or None: the index of the triangle hit (``si.prim_index``);
    * ``bary`` ``(N, 2)`` or None: the barycentric coordinates (b1, b2) of the hit with
      respect to the triangle's vertices ``faces[prim, 1]`` and ``faces[prim, 2]``, so that
      the point is (1 - b1 - b2) p0 + b1 p1 + b2 p2 (Mitsuba's ``prim_uv``; the order is that
      of the mesh's ``faces``, also for a shape with ``flip_normals``);
    * ``shape``: the mesh hit (an object with ``faces (F, 3)`` and ``vertex_attributes`` /
      ``face_attributes`` dicts of arrays), for ``mesh_attribute``;
    * ``p`` ``(N, 3)`` or None: the world-space position of the point (``si.p``), for the
      ``volume`` texture.
    """

    uv: np.ndarray
    prim: np.ndarray | None = None
    bary: np.ndarray | None = None
    shape: Any = None
    p: np.ndarray | None = None


def surface_points(si: Any, name: str = "si") -> SurfacePoints:
    """``si`` checked as a :class:`SurfacePoints` (a bare array is taken as its ``uv``):
    ``uv`` finite ``(N, 2)``, ``prim`` integers ``(N,)``, ``bary`` finite ``(N, 2)`` and ``p``
    finite ``(N, 3)`` when given.  ``TypeError``/``ValueError`` naming ``name`` and the field."""
    if not isinstance(si, SurfacePoints):
        si = SurfacePoints(si)
    uv = checks.finite_array(si.uv, f"{name}.uv", ndim=2, last=2)
    n = len(uv)
    prim = bary = None
    if si.prim is not None:
        prim = np.asarray(si.prim)
        if prim.dtype.kind not in "iu" or prim.shape != (n,):
            raise ValueError(f"{name}.prim must be integers of shape ({n},), got {prim.dtype} {prim.shape}")
    if si.bary is not None:
        bary = checks.finite_array(si.bary, f"{name}.bary", ndim=2, last=2)
        if len(bary) != n:
            raise ValueError(f"{name}.bary must have shape ({n}, 2), got {bary.shape}")
    p = None
    if si.p is not None:
        p = checks.finite_array(si.p, f"{name}.p", ndim=2, last=3)
        if len(p) != n:
            raise ValueError(f"{name}.p must have shape ({n}, 3), got {p.shape}")
    return SurfacePoints(uv, prim, bary, si.shape, p)


def take(si: SurfacePoints, index: np.ndarray) -> SurfacePoints:
    """The points ``index`` (a boolean mask or integer indices) of a checked ``si``."""
    return SurfacePoints(si.uv[index], None if si.prim is None else si.prim[index],
                         None if si.bary is None else si.bary[index], si.shape,
                         None if si.p is None else si.p[index])


def uv_transform(to_uv: Any, name: str = "to_uv") -> np.ndarray:
    """The 2 x 3 affine map [A | t] of a ``to_uv`` transform, uv' = A uv + t: Mitsuba 3
    convention (``ScalarTransform3f`` from a property, ``transform_affine``): a 3 x 3
    matrix gives its top two rows; a 4 x 4 one (as ``<transform>`` in a scene file makes)
    gives rows 0, 1 and columns 0, 1, 3 (its z row and column are dropped).  The bottom
    row is ignored, as Mitsuba's ``transform_affine`` does.  None is the identity."""
    if to_uv is None:
        return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    m = checks.finite_array(to_uv, name, ndim=2)
    if m.shape == (3, 3):
        return m[:2].copy()
    if m.shape == (4, 4):
        return m[:2][:, [0, 1, 3]].copy()
    raise ValueError(f"{name} must be a 3 x 3 or 4 x 4 matrix, got shape {m.shape}")


def apply_uv(affine: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """uv' = A uv + t for ``affine`` = [A | t] (2 x 3) and ``uv`` (N, 2)."""
    return uv @ affine[:, :2].T + affine[:, 2]


class Texture(Element):
    """Base of the texture elements (see the module docstring for the interface).

    Subclasses implement ``eval``, ``eval_1``, ``mean`` and ``mean_1``; ``is_constant`` is
    False unless overridden."""

    kind = "texture"
    is_constant = False

    @property
    def type(self) -> str:
        """The Mitsuba plugin name."""
        return self.plugin_name

    def eval(self, si: Any) -> np.ndarray:   # pragma: no cover - every texture overrides it
        """The RGB value ``(N, 3)`` at the surface points ``si``."""
        raise NotImplementedError

    def eval_1(self, si: Any) -> np.ndarray:   # pragma: no cover - every texture overrides it
        """The scalar value ``(N,)`` at the surface points ``si`` (Mitsuba's ``eval_1``)."""
        raise NotImplementedError

    def mean(self) -> np.ndarray:   # pragma: no cover - every texture overrides it
        """The mean RGB value ``(3,)`` over the uv square."""
        raise NotImplementedError

    def eval_1_grad(self, si: Any) -> np.ndarray:
        """``(N, 2)``: the gradient of ``eval_1`` with respect to the surface's uv (Mitsuba's
        ``eval_1_grad``, which ``bumpmap`` reads).  Default: not available."""
        raise ValueError(f"texture: a {self.plugin_name!r} texture has no uv gradient (bumpmap needs one; "
                         "use a bitmap)")

    def mean_1(self) -> float:   # pragma: no cover - every texture overrides it
        """Mitsuba 3's scalar ``Texture::mean()``."""
        raise NotImplementedError


class ConstantTexture(Texture):
    """A constant colour as a texture (Mitsuba 3's ``srgb``/``uniform`` textures, which a
    ``<rgb>``, ``<float>`` or ``<spectrum>`` parameter becomes in the RGB variants):
    ``eval`` = the colour, ``eval_1`` = ``mean_1`` = the mean of its channels (src/textures/
    srgb.cpp in RGB mode), ``mean`` = the colour.  Not a registered plugin."""

    is_constant = True

    def __init__(self, color: Any, *, name: str = "color"):
        c = checks.finite_array(color, name)
        if c.ndim == 0:
            c = np.full(3, float(c))
        if c.shape != (3,):
            raise ValueError(f"{name} must be a number, an RGB triple (3,) or a texture, got shape {c.shape}")
        self.color = c

    def eval(self, si: Any) -> np.ndarray:
        n = len(surface_points(si).uv)
        return np.broadcast_to(self.color, (n, 3)).copy()

    def eval_1(self, si: Any) -> np.ndarray:
        return np.full(len(surface_points(si).uv), self.mean_1())

    def eval_1_grad(self, si: Any) -> np.ndarray:
        return np.zeros((len(surface_points(si).uv), 2))

    def mean(self) -> np.ndarray:
        return self.color.copy()

    def mean_1(self) -> float:
        return float(self.color.mean())

    def __repr__(self) -> str:
        return f"ConstantTexture(color={self.color.tolist()})"


def as_texture(value: Any, name: str) -> Texture:
    """``value`` as a :class:`Texture`: a texture as it is, a number or an RGB triple as a
    :class:`ConstantTexture`.  ``TypeError``/``ValueError`` naming ``name``."""
    if isinstance(value, Texture):
        return value
    if isinstance(value, Element):
        raise TypeError(f"{name} must be a colour or a texture, got a {value.kind} ({type(value).__name__})")
    return ConstantTexture(value, name=name)
