"""Progress bars of long runs (lab sweeps, renders): a thin wrapper on ``tqdm``."""
from __future__ import annotations

import sys

from .. import checks

__all__ = ["ProgressBar"]


class ProgressBar:
    """A progress bar on ``stream`` (default stderr): a thin wrapper on ``tqdm``.

    ``disable``: False (default) shows the bar (whoever builds one asked for it: ``vrlab
    render --progress``), None hides it when the stream is not a terminal (tqdm's rule; what
    ``vrlab.lab.run(progress=True)`` uses), True never shows it.  ``width``: characters of
    the bar itself; ``unit``: what it counts (``"samples"``: the rate reads "2.3M samples/s",
    with SI prefixes); ``start``: the ``time.time()`` the work began, when the bar is made
    later (on its first report), so that the rate is not of the last unit alone.  ``update(k)``
    adds ``k`` finished items; ``done`` counts them; the bar closes (ends its
    line) when ``done`` reaches ``total``.  Checked: ``total`` an integer >= 0, ``width`` in
    [1, 200], ``label`` a string, ``stream`` with ``write`` and ``flush``, ``k`` an integer >= 0.
    """

    def __init__(self, total: int, stream=None, width: int = 30, label: str = "lab", disable: bool | None = False,
                 unit: str = "it", start: float | None = None):
        from tqdm import tqdm

        total = checks.integer(total, "total", low=0)
        width = checks.integer(width, "width", low=1, high=200)
        if not isinstance(label, str):
            raise TypeError(f"label must be a string, got {type(label).__name__}")
        if stream is not None and not (callable(getattr(stream, "write", None))
                                       and callable(getattr(stream, "flush", None))):
            raise TypeError(f"stream must be a text stream (write, flush) or None, got {type(stream).__name__}")
        if disable is not None:
            disable = checks.flag(disable, "disable")
        self.total, self.width, self.label, self.done = total, width, label, 0
        if not isinstance(unit, str) or not unit:
            raise TypeError(f"unit must be a non-empty string, got {unit!r}")
        self._bar = tqdm(total=total, desc=label, file=stream if stream is not None else sys.stderr,
                         disable=disable, mininterval=0.1, dynamic_ncols=True, unit=f" {unit}",
                         unit_scale=unit != "it",
                         bar_format="{l_bar}{bar:%d}{r_bar}" % width)
        if start is not None:   # the work began before the bar (made on the first report): rate from then
            self._bar.start_t = self._bar.last_print_t = float(start)

    def update(self, k: int = 1) -> None:
        k = checks.integer(k, "k", low=0)
        self.done += k
        self._bar.update(k)
        if self.done >= self.total:
            self.close()

    def close(self) -> None:
        self._bar.close()
