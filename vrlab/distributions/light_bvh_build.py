"""The top-down build of :class:`~vrlab.distributions.light_bvh.LightBVH`: pbrt-v4's binned
split by the surface area orientation heuristic, one NumPy pass per tree level over every node
of that level (see the light_bvh module docstring)."""
from __future__ import annotations

import numpy as np

from .light_bounds import Bounds, empty_bounds, split_cost, union

__all__ = ["split_sides", "N_BUCKETS"]

N_BUCKETS = 12


def _segments(key: np.ndarray):
    """``(order, starts, rank)``: a stable sort of ``key``, the first sorted position of
    each run of equal keys and each sorted item's rank within its run."""
    order = np.argsort(key, kind="stable")
    k = key[order]
    new = np.ones(len(k), bool)
    new[1:] = k[1:] != k[:-1]
    starts = np.flatnonzero(new)
    run = np.cumsum(new) - 1
    rank = np.arange(len(k)) - starts[run]
    return order, starts, rank, run


def _segment_union(b: Bounds, key: np.ndarray) -> tuple[np.ndarray, Bounds]:
    """``(keys, unions)``: the union of the records with each distinct ``key``, by a
    pairwise tree reduction (log2 of the longest run of NumPy steps)."""
    order, starts, rank, run = _segments(key)
    acc = b.take(order)
    size = np.diff(np.append(starts, len(order)))[run]
    s = 1
    while s < (size.max() if len(size) else 0):
        i = np.flatnonzero((rank % (2 * s) == 0) & (rank + s < size))
        acc.put(i, union(acc.take(i), acc.take(i + s)))
        s *= 2
    return key[order][starts], acc.take(starts)


def split_sides(b: Bounds, group: np.ndarray, n_groups: int) -> np.ndarray:
    """For lights ``b`` in nodes ``group`` (0..n_groups-1, each with >= 2 lights): True for
    the lights that go to child 1 (see the module docstring: binned SAOH, median fallback)."""
    G, B = n_groups, N_BUCKETS
    c = (b.lo + b.hi) / 2
    cmin = np.full((G, 3), np.inf)
    cmax = np.full((G, 3), -np.inf)
    np.minimum.at(cmin, group, c)
    np.maximum.at(cmax, group, c)
    bmin = np.full((G, 3), np.inf)
    bmax = np.full((G, 3), -np.inf)
    np.minimum.at(bmin, group, b.lo)
    np.maximum.at(bmax, group, b.hi)
    ext = cmax - cmin
    with np.errstate(invalid="ignore", divide="ignore"):
        bucket = np.minimum((B * (c - cmin[group]) / ext[group]).astype(np.int64, copy=False), B - 1)
    bucket = np.where(ext[group] > 0, np.clip(bucket, 0, B - 1), 0)              # (K, 3)
    # bucket bounds for every (axis, node, bucket) at once
    K = len(group)
    key = ((np.arange(3)[:, None] * G + group[None, :]) * B + bucket.T).ravel()
    keys, ub = _segment_union(b.take(np.tile(np.arange(K), 3)), key)
    buckets = empty_bounds(3 * G * B)
    buckets.put(keys, ub)
    buckets = Bounds(*(f.reshape((3 * G, B) + f.shape[1:]) for f in buckets))
    col = lambda i: Bounds(*(f[:, i] for f in buckets))               # noqa: E731
    # the scans from below and from above, one union of both per bucket (rows R.. from above)
    R = 3 * G
    below, above = [col(0)], [col(B - 1)]
    for i in range(1, B - 1):
        both = union(_stack(below[-1], above[-1]), _stack(col(i), col(B - 1 - i)))
        below.append(both.take(slice(0, R)))
        above.append(both.take(slice(R, None)))
    above = above[::-1]                                   # above[i]: buckets i+1 .. B-1
    diag = bmax - bmin                                    # (G, 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        kr = (diag.max(axis=1)[None, :] / diag.T).ravel()  # (3 G,)
    cost = np.empty((3 * G, B - 1))
    for i in range(B - 1):
        lo_, hi_ = below[i], above[i]
        ok = (lo_.phi > 0) & (hi_.phi > 0)
        with np.errstate(invalid="ignore"):
            cost[:, i] = np.where(ok, split_cost(lo_, kr) + split_cost(hi_, kr), np.inf)
    cost = np.where(np.isfinite(cost) & (cost > 0) & (ext.T.ravel() > 0)[:, None], cost, np.inf)
    cost = cost.reshape(3, G, B - 1).transpose(1, 0, 2).reshape(G, -1)
    best = np.argmin(cost, axis=1)
    sah = np.isfinite(cost[np.arange(G), best])
    axis, at = best // (B - 1), best % (B - 1)
    side = bucket[np.arange(K), axis[group]] > at[group]
    # median along the widest centroid axis where no split scored
    med = ~sah[group]
    if med.any():
        wide = np.argmax(ext, axis=1)
        coord = c[np.arange(K), wide[group]]
        order = np.lexsort((np.arange(K), coord, group))
        _, _, rank, _ = _segments(group[order])
        count = np.bincount(group, minlength=G)
        upper = np.empty(K, bool)
        upper[order] = rank >= count[group[order]] // 2
        side = np.where(med, upper, side)
    return side


def _stack(a: Bounds, b: Bounds) -> Bounds:
    """The records of a, then those of b."""
    return Bounds(*(np.concatenate([fa, fb]) for fa, fb in zip(a, b)))
