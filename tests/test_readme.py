"""The README's code that plugs estimators into the renderer runs as printed (at a small size),
and every repository path that README.md and docs/design.md mention exists."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DESIGN = ROOT / "docs" / "design.md"
#: first components of repository paths (``notebooks`` moved into ``vrlab/``: a stale mention fails)
REPO_DIRS = ("vrlab", "tests", "experiments", "benchmarks", "docs", ".ci", "notebooks")
#: suffixes that make a ``a/b.ext`` span a file path whatever its first component
FILE_SUFFIXES = (".py", ".ipynb", ".md", ".xml", ".npy", ".npz", ".png", ".toml", ".csv", ".sqlite")


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
    import sys
    import types

    import vrlab.estimators.registry as registry
    import vrlab.testing as T

    # the README's class lives in a script; here in a module of its own, checked in this process
    module = types.ModuleType("readme_example")
    monkeypatch.setitem(sys.modules, "readme_example", module)
    real_check = T.check_estimator
    monkeypatch.setattr(T, "check_estimator", lambda est, *a, **kw: real_check(est, *a, **{**kw, "spawn": False}))
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    namespace: dict = module.__dict__
    exec(compile(_section_code("Plug your own estimator into the renderer"), str(README), "exec"), namespace)
    assert namespace["named"].value.shape == (6, 8, 3)
    for name in ("mis", "pairs", "mine"):
        est = namespace[name]
        assert est.value.shape == (6, 8, 3) and np.all(np.isfinite(est.value)) and est.n == 16
    out = capsys.readouterr().out
    assert "LightThenBSDF" in out and "'render': 'ok'" in out


def test_your_own_scene_element_section_runs(capsys):
    """The registered element of the README loads from XML and renders (tint applied)."""
    from vrlab.render import registered

    namespace: dict = {}
    exec(compile(_section_code("Your own scene element"), str(README), "exec"), namespace)
    image = namespace["image"]
    assert image.shape == (24, 32, 3) and np.all(np.isfinite(image))
    floor = image[21, 16]
    assert floor[0] > floor[1] > floor[2] > 0                       # reflectance 0.5 x (1, 0.5, 0.25)
    assert floor[1] / floor[0] == pytest.approx(0.5, rel=1e-5)
    assert registered("bsdf")["tinted"] is namespace["Tinted"]
    assert "(24, 32, 3)" in capsys.readouterr().out


def _mentioned_paths(doc: Path) -> list[tuple[str, Path]]:
    """``(path, folder it is relative to)`` for every repository path ``doc`` mentions:
    markdown link and ``href``/``src`` targets (relative to ``doc``'s folder; URLs and
    ``#anchors`` left out, a ``#fragment`` dropped), and code spans without spaces that look
    like repository paths (relative to the root): ``vrlab/...``-style paths, ``a/b.py``-style
    files, or top-level ``NAME.md`` / ``NAME.toml``.  Fenced code blocks are left out: their
    paths are commands' outputs."""
    text = re.sub(r"^```.*?^```", "", doc.read_text(), flags=re.S | re.M)
    found = []
    for target in re.findall(r"\]\(\s*([^)\s]+)", text) + re.findall(r'(?:href|src)="([^"]+)"', text):
        if target.startswith("#") or re.match(r"[A-Za-z][A-Za-z0-9+.-]*:", target):
            continue
        found.append((target.split("#")[0], doc.parent))
    for span in re.findall(r"`([^`\s]+)`", text):
        if any(c in span for c in "<>{}|"):
            continue                                         # a placeholder, not a path
        first, name = span.split("/")[0], span.rstrip("/").split("/")[-1]
        if ("/" in span and (first in REPO_DIRS or name.endswith(FILE_SUFFIXES))) or \
                re.fullmatch(r"[A-Za-z_]+\.(md|toml)", span):
            found.append((span, ROOT))
    return found


@pytest.mark.parametrize("doc", [README, DESIGN], ids=lambda p: p.name)
def test_every_mentioned_repository_path_exists(doc):
    found = _mentioned_paths(doc)
    assert len(found) >= 5, f"{doc.name}: the path finder found almost nothing: {found}"
    missing = [path for path, base in found
               if not (any(base.glob(path)) if "*" in path else (base / path).exists())]
    assert not missing, f"{doc.relative_to(ROOT)} mentions paths that do not exist: {missing}"


def test_the_path_finder_sees_links_spans_and_skips_the_rest(tmp_path):
    doc = tmp_path / "x.md"
    doc.write_text("See [a](a/b.md#sec), [web](https://x.org/y), [top](#top), <img src=\"c/d.png\">,\n"
                   "`vrlab/render/`, `render/poisson.py`, `README.md`, `vrlab-out/NAME`, `vrlab.lab.run`,\n"
                   "`notebooks/01.ipynb`, `python -m vrlab.experiments.mis`, `<scene>_mean.npy`.\n"
                   "```bash\nvrlab render x -o out/img.png   # `docs/fenced.png`\n```\n")
    assert _mentioned_paths(doc) == [("a/b.md", tmp_path), ("c/d.png", tmp_path), ("vrlab/render/", ROOT),
                                     ("render/poisson.py", ROOT), ("README.md", ROOT),
                                     ("notebooks/01.ipynb", ROOT)]


def test_the_veach_figure_numbers_come_from_its_command(tmp_path):
    """The relMSE values the README quotes under the Veach figure are what its command gives
    (the images are a function of the seed; only the seconds vary)."""
    from vrlab.render.compare import compare

    text = README.read_text()
    assert "vrlab render veach_mis --spp 16 --width 192 --height 144 --compare -o docs/veach_mis.png" in text
    quoted = re.search(r"25\.0 \(bsdf\), 0\.682 \(light\) and 0\.0424 \(mis-power\)", text)
    assert quoted, "the README's Veach numbers changed: update this test with the command's new output"
    from vrlab.render import load_scene
    from vrlab.render.builtin import builtin_scene_path

    scene = load_scene(builtin_scene_path("veach_mis"))                # --width 192 --height 144, as the CLI does
    scene = scene.with_size(192, 144)
    res = compare(scene, ["bsdf", "light", "mis-power"], 16, rng=0, ref_spp=256, points="independent", workers=1)
    got = res["rel_mse"]
    assert got["bsdf"] == pytest.approx(25.0, rel=0.01) and got["light"] == pytest.approx(0.682, rel=0.01)
    assert got["mis-power"] == pytest.approx(0.0424, rel=0.01)
