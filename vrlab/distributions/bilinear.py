"""Piecewise-bilinear densities on the unit square, sampled exactly (area measure).

``BilinearPiecewise2D(values, table="cdf")`` takes vertex values ``V[j, i] >= 0`` of shape
(H + 1, W + 1) on the grid ``x_i = i / W``, ``y_j = j / H`` of [0, 1]^2 (``values[j, i]``:
row j is y, column i is x, as in ``PiecewiseConstant2D``).  Inside cell (j, i), with local
coordinates ``s = x W - i``, ``t = y H - j`` in [0, 1]::

    f(x, y) = (1 - t) ((1 - s) V00 + s V10) + t ((1 - s) V01 + s V11),
    V00 = V[j, i], V10 = V[j, i+1], V01 = V[j+1, i], V11 = V[j+1, i+1],
    p(x, y) = f(x, y) / mean(m),    m[j, i] = (V00 + V10 + V01 + V11) / 4,

``m`` being the integral of f over the cell times W H (the cell masses), so p integrates to 1.
This is the density of Mitsuba 3's ``Hierarchical2D`` / ``Marginal2D`` warps (Mitsuba 3
convention, include/mitsuba/core/distr_2d.h: the linear interpolant of the data over its
``size - 1`` patches, scaled by ``n_patches / sum(patch averages)``).

Sampling (exact inversion):

1. **Cell** by its mass ``m``: ``table="cdf"`` takes the row j from the marginal CDF of the
   row masses with ``u_2`` (``CDFTable``) and the column i from row j's conditional CDF with
   ``u_1`` (binary search), each leaving its uniform rescaled to [0, 1) (``r_x``, ``r_y``):
   a monotone bijection, so ``invert`` exists.  ``table="alias"`` picks the cell from the
   flattened masses with ``u_1`` (``AliasTable``, O(1)), ``r_x`` its remapped uniform and
   ``r_y = u_2`` (not invertible: ``invert`` is absent).
2. **Inside the cell** ("bilinear patch" warp; facts from pbrt-v4, Pharr, Jakob and Humphreys,
   Physically Based Rendering 4th ed., ch. 2, ``SampleBilinear``, and Mitsuba 3's
   ``warp::square_to_bilinear``, include/mitsuba/core/warp.h): the marginal of t is linear with
   end values ``a = V00 + V10``, ``b = V01 + V11``; then s given t is linear with end values
   ``a = lerp(t, V00, V01)``, ``b = lerp(t, V10, V11)``.  A linear density on [0, 1] with end
   values a, b has the CDF ``F(t) = t (a (2 - t) + b t) / (a + b)``; its inverse, the root of a
   quadratic written without cancellation (both terms of the denominator are >= 0)::

       t = r (a + b) / (a + sqrt((1 - r) a^2 + r b^2))        (t = r where a = b = 0)

   with a, b first divided by max(a, b) (no overflow or underflow of the squares).

``pdf(x)`` is p above (0 outside [0, 1]^2; a point on an inner edge belongs to the cell above
and to the right, the right and top boundary to the last cell), ``sample_pdf`` returns it from
the sampled cell and local coordinates, ``invert(x)`` applies F in t and in s given t and the
row / column CDFs.  A sample never leaves its cell (x < (i + 1) / W, y < (j + 1) / H).

Checked at construction (``TypeError`` / ``ValueError`` naming the argument): ``values`` a 2-D
array of at least 2 x 2 finite values >= 0, not all zero; ``table`` one of ``TABLES``.
``sample``, ``pdf`` and ``invert`` check only shapes (hot path; the tables check u in [0, 1)).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks
from .base import Distribution, as_points, as_uniforms
from .discrete import AliasTable, CDFTable
from .tabulated import check_weights

__all__ = ["BilinearPiecewise2D", "sample_linear", "linear_cdf"]

TABLES = ("cdf", "alias")
_ONE_MINUS = float(np.nextafter(1.0, 0.0))


def sample_linear(r: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Inverse CDF of the density proportional to ``(1 - t) a + t b`` on [0, 1] (a, b >= 0):
    ``t = r (a + b) / (a + sqrt((1 - r) a^2 + r b^2))``, the stable root of
    ``t (a (2 - t) + b t) = r (a + b)`` (pbrt-v4 ``SampleLinear``; uniform where a = b = 0).
    Arrays broadcast; a and b are rescaled by max(a, b) first."""
    m = np.maximum(a, b)
    scale = np.where(m > 0, m, 1.0)
    a, b = a / scale, b / scale
    root = np.sqrt((1.0 - r) * a * a + r * b * b)
    den = a + root
    t = np.where(den > 0, r * (a + b) / np.where(den > 0, den, 1.0), r)
    return np.clip(t, 0.0, 1.0)


def linear_cdf(t: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """CDF of the density proportional to ``(1 - t) a + t b`` on [0, 1]:
    ``F(t) = t (a (2 - t) + b t) / (a + b)`` (``F(t) = t`` where a = b = 0); the inverse of
    :func:`sample_linear` (pbrt-v4 `InvertLinearSample`)."""
    s = a + b
    return np.where(s > 0, t * (a * (2.0 - t) + b * t) / np.where(s > 0, s, 1.0), t)


def _values(values: Any) -> np.ndarray:
    v = check_weights(values, "values", 2)
    if v.shape[0] < 2 or v.shape[1] < 2:
        raise ValueError(f"values: expected vertex values of shape (H + 1, W + 1) with H, W >= 1 "
                         f"(at least 2 x 2), got shape {v.shape}")
    return v


class BilinearPiecewise2D(Distribution):
    """Density on [0, 1]^2 bilinear inside each of the H x W cells of the vertex grid
    ``values (H + 1, W + 1)`` (measure: area); formulas and sources in the module docstring.

    ``BilinearPiecewise2D(values, table="cdf")``: ``sample(u (..., 2)) -> x (..., 2)``,
    ``pdf(x) = f(x) / mean(m)``, ``sample_pdf(u)``, ``invert(x) -> u`` (``table="cdf"`` only:
    an alias table is not a bijection, ``hasattr`` is False).  Attributes: ``values``
    (float64, as given, or scaled by a power of two if their sum would overflow), ``nx`` W,
    ``ny`` H, ``masses`` (H, W) cell masses m, ``norm`` = mean(m), ``table``.
    """

    dim_u = dim_x = 2
    measure = "area"
    TABLES = TABLES

    def __init__(self, values: Any, table: str = "cdf"):
        v = _values(values)
        self.table = checks.choice(table, "table", TABLES)
        self.values = v
        self.ny, self.nx = v.shape[0] - 1, v.shape[1] - 1
        self.masses = 0.25 * ((v[:-1, :-1] + v[:-1, 1:]) + (v[1:, :-1] + v[1:, 1:]))
        self.norm = float(self.masses.mean())
        if not self.norm > 0:   # not reached for finite values >= 0 that are not all zero
            raise ValueError("values: the cells have zero total mass")
        with np.errstate(over="ignore"):
            self._density = v / self.norm                    # p at the vertices
        if not np.all(np.isfinite(self._density)):
            raise ValueError("values: too uneven: the normalised density overflows")
        self._v00, self._v10 = self._density[:-1, :-1], self._density[:-1, 1:]
        self._v01, self._v11 = self._density[1:, :-1], self._density[1:, 1:]
        self._size = np.array([self.nx, self.ny], float)
        if self.table == "alias":
            self._alias = AliasTable(self.masses.ravel())
        else:
            self._alias = None
            rows = self.masses.sum(axis=1)
            self._rows = CDFTable(rows)                      # marginal: the row j from u_2
            self._row_lo = np.concatenate([[0.0], self._rows.cdf[:-1]])
            c = np.cumsum(self.masses, axis=1)
            total = c[:, -1:]
            c = np.where(total > 0, c / np.where(total > 0, total, 1.0), 0.0)
            c[:, -1] = np.where(total[:, 0] > 0, 1.0, 0.0)
            self._cond = np.concatenate([np.zeros((self.ny, 1)), c], axis=1)   # (H, W + 1)
            # row j's CDF shifted into [j, j + 1]: one searchsorted serves every row
            self._flat = (self._cond[:, :-1] + np.arange(self.ny)[:, None]).ravel()

    # -- cells ---------------------------------------------------------------------------
    def _cell_choice(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(j, i, r_x, r_y)``: the cell and the uniforms left for the patch (flat arrays)."""
        u1, u2 = u[:, 0], u[:, 1]
        if self._alias is not None:
            k, rx = self._alias.sample(u1, return_remapped=True)
            j, i = np.divmod(k, self.nx)
            return j, i, rx, u2
        j, ry = self._rows.sample(u2, return_remapped=True)
        k = np.searchsorted(self._flat, j + u1, side="right") - 1
        i = np.clip(k - j * self.nx, 0, self.nx - 1)
        lo, hi = self._cond[j, i], self._cond[j, i + 1]
        rx = np.where(hi > lo, (u1 - lo) / np.where(hi > lo, hi - lo, 1.0), 0.0)   # chosen cells: hi > lo
        return j, i, np.clip(rx, 0.0, _ONE_MINUS), ry

    def _corners(self, j: np.ndarray, i: np.ndarray):
        return self._v00[j, i], self._v10[j, i], self._v01[j, i], self._v11[j, i]

    def _locate(self, x: np.ndarray):
        """Flat points -> ``(j, i, s, t, inside)``."""
        g = x * self._size
        ij = np.fmin(np.fmax(np.floor(g), 0), self._size - 1).astype(np.intp)   # NaN -> cell 0 (pdf 0)
        st = g - ij
        inside = np.all((x >= 0.0) & (x <= 1.0), -1)
        return ij[:, 1], ij[:, 0], st[:, 0], st[:, 1], inside

    # -- protocol ------------------------------------------------------------------------
    def sample_pdf(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(x, pdf(x))`` for uniforms ``u (..., 2)``: the cell by its mass, then t from the
        linear marginal and s from the linear conditional (module docstring)."""
        u = as_uniforms(u, 2)
        shape = u.shape[:-1]
        uf = u.reshape(-1, 2).astype(np.float64, copy=False)
        j, i, rx, ry = self._cell_choice(uf)
        v00, v10, v01, v11 = self._corners(j, i)
        t = sample_linear(ry, v00 + v10, v01 + v11)
        a, b = v00 + t * (v01 - v00), v10 + t * (v11 - v10)
        s = sample_linear(rx, a, b)
        p = (1.0 - s) * a + s * b
        x = np.clip((i + s) / self.nx, i / self.nx, np.nextafter((i + 1) / self.nx, -np.inf))
        y = np.clip((j + t) / self.ny, j / self.ny, np.nextafter((j + 1) / self.ny, -np.inf))
        return np.stack([x, y], -1).reshape(shape + (2,)), p.reshape(shape)

    def sample(self, u: np.ndarray) -> np.ndarray:
        """Points ``(..., 2)`` in [0, 1)^2 for uniforms ``u (..., 2)`` (see ``sample_pdf``)."""
        return self.sample_pdf(u)[0]

    def pdf(self, x: np.ndarray) -> np.ndarray:
        """Density per unit area ``f(x) / mean(m)`` at points ``x (..., 2)`` (0 outside [0, 1]^2)."""
        x = as_points(x, 2)
        shape = x.shape[:-1]
        j, i, s, t, inside = self._locate(x.reshape(-1, 2).astype(np.float64, copy=False))
        v00, v10, v01, v11 = self._corners(j, i)
        p = (1.0 - t) * ((1.0 - s) * v00 + s * v10) + t * ((1.0 - s) * v01 + s * v11)
        return np.where(inside, p, 0.0).reshape(shape)

    def _invert(self, x: np.ndarray) -> np.ndarray:
        x = as_points(x, 2)
        shape = x.shape[:-1]
        j, i, s, t, _ = self._locate(x.reshape(-1, 2).astype(np.float64, copy=False))
        v00, v10, v01, v11 = self._corners(j, i)
        ry = linear_cdf(t, v00 + v10, v01 + v11)
        rx = linear_cdf(s, v00 + t * (v01 - v00), v10 + t * (v11 - v10))
        u2 = self._row_lo[j] + ry * (self._rows.cdf[j] - self._row_lo[j])
        u1 = self._cond[j, i] + rx * (self._cond[j, i + 1] - self._cond[j, i])
        return np.stack([u1, u2], -1).reshape(shape + (2,))

    @property
    def invert(self):
        """``invert(x) -> u (..., 2)``, the uniforms that ``sample`` maps to ``x``
        (``table="cdf"`` only): ``u_2`` from the row CDF and F(t), ``u_1`` from the row's
        conditional CDF and F(s | t)."""
        if self._alias is not None:
            raise AttributeError("invert: an alias table is not a bijection; build with table='cdf' to invert")
        return self._invert

    def _repr_fields(self) -> dict:
        return {"shape": self.values.shape, "table": self.table}
