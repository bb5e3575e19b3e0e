"""Every python block of the README runs as a user runs it: saved as a script and run with
``python snippet.py`` in a fresh process (so check_estimator's spawn check really spawns); the
blocks' results are what the README says; every repository path that README.md and
docs/design.md mention exists."""
from __future__ import annotations

import os
import re
import subprocess
import sys
import warnings
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


def _python_blocks() -> list[tuple[str, str]]:
    """``(heading, code)`` of every ```python block of the README, the heading it stands under."""
    text = README.read_text()
    out = []
    for m in re.finditer(r"```python\n(.*?)```", text, re.S):
        heading = re.findall(r"^#+ (.+)$", text[:m.start()], re.M)[-1]
        out.append((heading, m.group(1)))
    return out


BLOCKS = _python_blocks()
#: what the test reads back from a block's script: names whose value (``.value`` for an Estimate) it saves
KEEP = {"Plug your own estimator into the renderer": ("mis", "pairs", "mine", "named"),
        "Your own scene element": ("image",)}
#: a Dask scheduler address the README assumes is running; the test starts a local one instead
README_SCHEDULER = "tcp://127.0.0.1:8786"


def _run_script(code: str, tmp_path: Path, keep: tuple[str, ...] = ()) -> tuple[str, dict]:
    """Save ``code`` as ``snippet.py`` and run ``python snippet.py`` in a fresh process, as a user
    does (so worker processes started with the spawn method re-run it).  After the block, an
    epilogue under the main guard saves the values of ``keep`` to ``snippet_out.npz``.
    Returns (stdout, the saved arrays); a failing script fails with its stderr."""
    epilogue = ("\nif __name__ == \"__main__\":\n    import numpy as _np\n"
                f"    _g = {{k: globals()[k] for k in {list(keep)!r}}}\n"
                "    _np.savez('snippet_out.npz', **{k: _np.asarray(getattr(v, 'value', v)) for k, v in _g.items()},\n"
                "              **{k + '.n': _np.asarray(v.n) for k, v in _g.items() if hasattr(v, 'n')})\n") if keep else ""
    script = tmp_path / "snippet.py"
    script.write_text(code + epilogue)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.run([sys.executable, script.name], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, f"python snippet.py failed:\n{code}\n--- stderr:\n{proc.stderr[-3000:]}"
    saved = dict(np.load(tmp_path / "snippet_out.npz")) if keep else {}
    return proc.stdout, saved


def _local_scheduler():
    """A Dask scheduler on 127.0.0.1 with one worker thread in this process (closed by the caller)."""
    distributed = pytest.importorskip("distributed")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                                        host="127.0.0.1", dashboard_address=None)


@pytest.mark.parametrize("heading, code", BLOCKS, ids=[f"{i}-{h[:30]}" for i, (h, _) in enumerate(BLOCKS)])
def test_every_python_block_runs_as_a_script(heading, code, tmp_path):
    """Each block, saved as a script and run with ``python snippet.py``, exits 0; the blocks whose
    results are checked below give what the README says of them."""
    if README_SCHEDULER in code:
        cluster = _local_scheduler()
        try:
            out, saved = _run_script(code.replace(README_SCHEDULER, cluster.scheduler_address), tmp_path)
        finally:
            cluster.close()
        return
    out, saved = _run_script(code, tmp_path, KEEP.get(heading, ()))
    if heading == "Plug your own estimator into the renderer":
        for name in ("mis", "pairs", "mine", "named"):
            value = saved[name]
            assert value.ndim == 3 and value.shape[2] == 3 and np.all(np.isfinite(value)), name
            assert int(saved[name + ".n"]) == 16
        assert "LightThenBSDF" in out and "'render': 'ok'" in out and "'pickle': 'ok'" in out, out
    elif heading == "Your own scene element":
        image = saved["image"]
        assert image.shape == (24, 32, 3) and np.all(np.isfinite(image))
        floor = image[21, 16]
        assert floor[0] > floor[1] > floor[2] > 0                       # reflectance 0.5 x (1, 0.5, 0.25)
        assert floor[1] / floor[0] == pytest.approx(0.5, rel=1e-5)
        assert "(24, 32, 3)" in out


def test_the_blocks_are_found():
    """The block finder sees every python block (a renamed heading would drop a block's checks)."""
    assert len(BLOCKS) == README.read_text().count("```python\n") >= 6
    assert set(KEEP) <= {h for h, _ in BLOCKS}


_SCRIPT = """from vrlab.estimators import MonteCarlo
from vrlab.testing import check_estimator

class Plain(MonteCarlo):                 # a user's class, defined in the script
    pass
"""


@pytest.mark.parametrize("variant", ["unguarded", "child dies", "guarded"])
def test_check_estimator_names_the_missing_main_guard(variant, tmp_path):
    """A class defined in a script run as ``python script.py``: check_estimator's spawn check
    tells an unguarded script to add ``if __name__ == "__main__":`` (before spawning), says so
    too when the spawned child dies re-running the script, and passes a guarded script."""
    call = "print(check_estimator(Plain(), 'sin', render=False))\n"
    code = _SCRIPT + {"unguarded": call,
                      "child dies": "if __name__ != '__main__':\n    raise SystemExit(3)\n"
                                    "if __name__ == '__main__':\n    " + call,
                      "guarded": "if __name__ == '__main__':\n    " + call}[variant]
    script = tmp_path / "script.py"
    script.write_text(code)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.run([sys.executable, script.name], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)
    if variant == "guarded":
        assert proc.returncode == 0 and "'pickle': 'ok'" in proc.stdout, proc.stderr[-2000:]
        return
    last = proc.stderr.strip().splitlines()[-1]
    assert proc.returncode != 0 and last.startswith("AssertionError: check_estimator[pickle]"), proc.stderr[-2000:]
    assert 'if __name__ == "__main__":' in last and "script.py" in last and "Plain" in last, last
    assert "importable by module path" not in last
    assert ("died" in last) == (variant == "child dies"), last


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


def _readme_strategies(text: str) -> dict[str, str]:
    """``{strategy: bias}`` from the README's strategy list: the bullets after "The strategies
    (`--strategy`" up to the first blank line, each "- `a` / `b` (bias): ..."."""
    start = text.index("The strategies (`--strategy`")
    block = text[start:text.index("\n\n", start)]
    out = {}
    for names, bias in re.findall(r"^- ((?:`[^`]+`(?:, | / | and )?)+) \((\w+)\):", block, re.M):
        for name in re.findall(r"`([^`]+)`", names):
            assert name not in out, f"the README lists strategy {name!r} twice"
            out[name] = bias
    return out


def test_the_readme_strategy_list_is_the_registry():
    """Every render recipe is in the README's strategy list with the bias its recipe states
    (``Recipe.bias``), and nothing else is; a list missing one, or with a wrong bias, fails."""
    from vrlab.estimators import recipes

    expected = {name: r.bias for name, r in recipes("render").items()}
    text = README.read_text()
    assert _readme_strategies(text) == expected
    dropped = text.replace(" / `mis-optimal` (unbiased)", " (unbiased)")
    assert _readme_strategies(dropped) != expected                      # the parser sees a missing name
    wrong = text.replace("- `cv` (unbiased)", "- `cv` (consistent)")
    assert _readme_strategies(wrong) != expected                        # ... and a wrong bias


def test_the_demo_timings_name_their_benchmark_machine_and_load():
    """The README's demo timings say which command measured them, on how many cores, under
    which load, and quote the budgets that vrlab.cli.DEMO_BUDGET_S (``vrlab demo --help``) states."""
    from vrlab.cli import DEMO_BUDGET_S

    text = " ".join(README.read_text().split())
    start = text.index("`vrlab demo --quick` took")
    sentence = text[start:text.index("`vrlab demo --help`", start)]
    for words in ("`python benchmarks/bench_demo.py`", "2 cores", "load average"):
        assert words in sentence, words
    assert f"budgets, {DEMO_BUDGET_S['quick']:g} s and {DEMO_BUDGET_S['full'] / 60:g} min" in sentence
