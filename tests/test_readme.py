"""The README's code that plugs estimators into the renderer runs as printed (at a small size)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def _section_code(title: str) -> str:
    text = README.read_text()
    start = text.index(f"### {title}")
    end = text.index("\n### ", start + 4)
    blocks = re.findall(r"```python\n(.*?)```", text[start:end], re.S)
    assert len(blocks) == 1, f"expected one python block in {title!r}"
    return blocks[0]


def test_plug_your_own_estimator_section_runs(monkeypatch, capsys):
    """The code runs as printed, except that every render is made small (8 x 6 pixels) to keep
    the suite fast; the user's estimator and heuristic then give finite images."""
    import vrlab.render as R

    real = R.render

    def small(*args, **kwargs):
        return real(*args, **{**kwargs, "width": 8, "height": 6})

    monkeypatch.setattr(R, "render", small)
    namespace: dict = {}
    exec(compile(_section_code("Plug your own estimator into the renderer"), str(README), "exec"), namespace)
    for name in ("mis", "pairs", "mine"):
        est = namespace[name]
        assert est.value.shape == (6, 8, 3) and np.all(np.isfinite(est.value)) and est.n == 16
    assert "LightThenBSDF" in capsys.readouterr().out
