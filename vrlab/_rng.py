"""One place where user-supplied randomness is normalised.

``rng`` may be ``None`` (fresh OS entropy), an int seed (or a list of them), a ``SeedSequence``, a
``BitGenerator`` or a ``Generator``; the semantics are those of
``numpy.random.default_rng``.  Independent streams for work units come from
``SeedSequence.spawn`` (never from re-seeding with consecutive integers).
"""
from __future__ import annotations

from typing import Union

import numpy as np

RNGLike = Union[None, int, np.integer, np.random.SeedSequence, np.random.BitGenerator, np.random.Generator]


def as_generator(rng: RNGLike = None) -> np.random.Generator:
    """Return a ``numpy.random.Generator`` for any accepted ``rng`` value."""
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, (bool, np.bool_)):
        raise TypeError(f"rng: expected None, an int seed, a SeedSequence, BitGenerator or Generator, got {rng!r}")
    if rng is None or isinstance(rng, (int, np.integer, np.random.SeedSequence, np.random.BitGenerator)):
        if isinstance(rng, (int, np.integer)) and rng < 0:
            raise ValueError(f"rng: a seed must be non-negative, got {rng}")
        return np.random.default_rng(rng)
    if isinstance(rng, (list, tuple)) and rng and all(isinstance(k, (int, np.integer)) and k >= 0 for k in rng):
        return np.random.default_rng(list(rng))  # a sequence of ints is SeedSequence entropy
    raise TypeError(
        "rng: expected None, an int seed, a numpy SeedSequence, BitGenerator or Generator, "
        f"got {type(rng).__name__}"
    )


def spawn(rng: RNGLike, k: int) -> list[np.random.Generator]:
    """``k`` statistically independent generators derived from ``rng``.

    With a seed or ``SeedSequence`` this is ``SeedSequence(rng).spawn(k)``, so the
    i-th child depends only on the seed and ``i`` (reproducible per work unit).
    With a ``Generator`` the children come from its bit generator's ``spawn``.
    """
    if isinstance(k, (bool, np.bool_)) or not isinstance(k, (int, np.integer)):
        raise TypeError(f"k must be an integer, got {k!r}")
    if k < 0:
        raise ValueError(f"k must be >= 0, got {k}")
    if isinstance(rng, (bool, np.bool_)):
        raise TypeError(f"rng: cannot spawn from a bool ({rng!r}); give an int seed")
    if isinstance(rng, np.random.Generator):
        return rng.spawn(k)
    if isinstance(rng, np.random.SeedSequence):
        seq = rng
    elif rng is None or isinstance(rng, (int, np.integer)):
        if rng is not None and rng < 0:
            raise ValueError(f"rng: a seed must be non-negative, got {rng}")
        seq = np.random.SeedSequence(rng)
    elif isinstance(rng, np.random.BitGenerator):
        return np.random.Generator(rng).spawn(k)
    else:
        raise TypeError(f"rng: cannot spawn from {type(rng).__name__}")
    return [np.random.default_rng(s) for s in seq.spawn(k)]


def as_seed_sequence(rng: RNGLike) -> np.random.SeedSequence:
    """A root ``SeedSequence`` for work split into units: ``rng`` itself, or built from its
    entropy (an int or a list of ints; ``None``: fresh OS entropy), or 4 words drawn from a
    ``Generator``/``BitGenerator`` (which advances it)."""
    if isinstance(rng, np.random.SeedSequence):
        return rng
    if isinstance(rng, (np.random.Generator, np.random.BitGenerator)):
        gen = rng if isinstance(rng, np.random.Generator) else np.random.Generator(rng)
        return np.random.SeedSequence([int(x) for x in gen.integers(0, 2**63, size=4)])
    as_generator(rng)                          # validates ints, int lists and None
    return np.random.SeedSequence(list(rng) if isinstance(rng, (list, tuple)) else rng)


def unit_seed(root: np.random.SeedSequence, *indices: int) -> np.random.SeedSequence:
    """The seed of one work unit: the spawn-tree child of ``root`` at ``indices``
    (``unit_seed(root, a, b) == root.spawn(.)[a].spawn(.)[b]`` for small indices), without
    spawning the siblings."""
    return np.random.SeedSequence(root.entropy, spawn_key=tuple(root.spawn_key) + tuple(int(i) for i in indices),
                                  pool_size=root.pool_size)

