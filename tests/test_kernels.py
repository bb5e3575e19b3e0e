"""Compiled kernels (vrlab.kernels, issue 31): the switch, lazy loading, the compile notice, the
cache folder, and parity of each Numba kernel with its NumPy oracle.

Parity: the alias table (``alias_kernel``) and the light-BVH walk (``light_bvh_kernel``)
against the NumPy code on random and adversarial inputs.  Each parity check is shown to
fail on mutants of the kernel: the kernel module's source with one change, run as plain
Python (no compilation; the same code the compiler sees), substituted by monkeypatching the
loader; the unchanged source run the same way passes (the control).
"""
from __future__ import annotations

import inspect
import os
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import numpy as np
import pytest

import vrlab.kernels as K
from vrlab.distributions import LightBVH, alias_build, alias_kernel, light_bvh_kernel
from vrlab.distributions.discrete import AliasTable

ROOT = Path(__file__).resolve().parents[1]


# -- the switch -------------------------------------------------------------------------------
def test_resolve_kernels(raises_naming, monkeypatch):
    assert K.resolve_kernels("numpy") == "numpy"
    assert K.resolve_kernels("numba") == K.resolve_kernels("auto") == "numba"     # numba is in the venv
    for bad in ("Numba", "cuda", None, 1, ""):
        with raises_naming(ValueError, "kernels"):
            K.resolve_kernels(bad)
    monkeypatch.setattr(K, "numba_version", lambda: None)                          # as where numba has no wheel
    assert K.resolve_kernels("auto") == "numpy"
    with raises_naming(ValueError, "kernels"):
        K.resolve_kernels("numba")
    with raises_naming(ValueError, "kernels"):
        AliasTable(np.ones(3) + np.arange(3), kernels="numba")
    with raises_naming(ValueError, "name"):
        K.load_kernel("vrlab.distributions.alias_kernel", "no_such_kernel")


def test_auto_alias_table_uses_numpy_below_the_threshold():
    small, big = np.arange(1.0, 101.0), np.arange(1.0, alias_build.NUMBA_FROM + 1.0)
    assert AliasTable(small).kernels == "numpy" and AliasTable(big).kernels == "numba"
    assert AliasTable(small, kernels="numba").kernels == "numba"
    assert LightBVH(np.zeros((2, 3)), np.ones((2, 3)), [[0, 0, 1]] * 2, [1, 1], [0, 0], [1, 2]).kernels == "numpy"


def _run(code: str, env_extra: dict | None = None) -> subprocess.CompletedProcess:
    """``code`` in a fresh Python with this checkout first on the path, no NUMBA_CACHE_DIR, and
    ``env_extra`` (its PYTHONPATH goes after the checkout)."""
    extra = dict(env_extra or {})
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(extra, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), extra.get("PYTHONPATH", "")])))
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          check=True, env=env)


def test_importing_vrlab_imports_no_numba():
    out = _run("""
        import sys
        import numpy as np
        import vrlab, vrlab.render, vrlab.kernels, vrlab.distributions
        from vrlab.distributions import LightBVH
        vrlab.AliasTable(np.arange(1.0, 1000.0))                 # "auto" below the threshold
        b = LightBVH(np.zeros((3, 3)), np.ones((3, 3)), [[0, 0, 1]] * 3, [1] * 3, [0] * 3, [1, 2, 3])
        b.sample(np.full((4, 3), 2.0), None, np.full(4, 0.5))   # the default walk: numpy
        vrlab.kernels.resolve_kernels("numpy")
        print("numba" in sys.modules, "vrlab.distributions.alias_kernel" in sys.modules)
        vrlab.kernels.resolve_kernels("auto")                    # imports numba, compiles nothing
        print("numba" in sys.modules)
        """).stdout.split()
    assert out == ["False", "False", "True"], out


# -- the notice and the cache folder -----------------------------------------------------------
TOY = '''
from numba import njit

SIGNATURES = {"twice": ["float64(float64)"]}
COMPILE_SECONDS = 2.4


@njit(cache=True)
def twice(x):
    return 2.0 * x
'''

LOAD = """
    import sys
    from vrlab.kernels import load_kernel, load_kernels
    assert load_kernel("toy_kernel", "twice")(1.5) == 3.0
    load_kernels("toy_kernel", "toy_kernel")                     # loaded: nothing more
    print(sorted(load_kernels("toy_kernel")))
"""
NOTICE = "vrlab: compiling render kernels, once: about 2 s"


def _toy(folder: Path) -> Path:
    folder.mkdir()
    (folder / "toy_kernel.py").write_text(TOY)
    return folder


def test_first_use_compiles_with_one_line_then_loads_from_the_cache(tmp_path):
    pkg = _toy(tmp_path / "pkg")
    first = _run(LOAD, {"PYTHONPATH": str(pkg)})
    assert first.stderr.splitlines() == [NOTICE] and first.stdout.split() == ["['toy_kernel']"]
    assert list((pkg / "__pycache__").glob("toy_kernel.twice-*.nbi"))               # next to the module
    second = _run(LOAD, {"PYTHONPATH": str(pkg)})
    assert second.stderr == "", second.stderr                                      # from the cache: silent


def test_one_notice_for_several_modules(tmp_path):
    pkg = _toy(tmp_path / "pkg")
    (pkg / "toy2_kernel.py").write_text(TOY.replace("2.4", "1.3"))
    out = _run("""
        from vrlab.kernels import load_kernels
        load_kernels("toy_kernel", "toy2_kernel")
        """, {"PYTHONPATH": str(pkg)})
    assert out.stderr.splitlines() == ["vrlab: compiling render kernels, once: about 4 s"]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the user cache folder follows XDG on Linux")
def test_cache_goes_to_the_user_cache_folder_where_the_package_is_not_writable(tmp_path):
    """A package folder numba cannot write (here: ``__pycache__`` is a file, which stops root
    too): the compiled code goes to $XDG_CACHE_HOME/numba, and the next process loads it."""
    pkg = _toy(tmp_path / "pkg")
    (pkg / "__pycache__").write_text("not a folder")
    env = {"PYTHONPATH": str(pkg), "XDG_CACHE_HOME": str(tmp_path / "xdg"), "PYTHONDONTWRITEBYTECODE": "1"}
    first = _run(LOAD, env)
    assert first.stderr.splitlines() == [NOTICE]
    assert list((tmp_path / "xdg" / "numba").rglob("toy_kernel.twice-*.nbi"))
    assert _run(LOAD, env).stderr == ""


def test_numba_requirement_leaves_out_platforms_without_wheels():
    from packaging.requirements import Requirement

    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    (req,) = [Requirement(d) for d in deps if d.startswith("numba")]
    base = {"python_version": "3.12", "platform_python_implementation": "CPython"}
    wheels = [("linux", "x86_64"), ("linux", "aarch64"), ("darwin", "arm64"), ("win32", "AMD64")]
    none = [("darwin", "x86_64"), ("win32", "ARM64"), ("linux", "ppc64le")]
    for plat, machine in wheels + none:
        env = dict(base, sys_platform=plat, platform_machine=machine)
        assert req.marker.evaluate(env) == ((plat, machine) in wheels), (plat, machine)
    assert not req.marker.evaluate(dict(base, sys_platform="linux", platform_machine="x86_64",
                                        platform_python_implementation="PyPy"))


# -- mutants ---------------------------------------------------------------------------------
def as_python(module, *changes: tuple[str, str]) -> dict:
    """The functions of kernel ``module`` as plain Python, after replacing each ``old`` by
    ``new`` in its source (each must occur)."""
    src = inspect.getsource(module)
    for old, new in changes:
        assert old in src, old
        src = src.replace(old, new)
    src = src.replace("from numba import njit\n", "").replace('@njit(cache=True, error_model="numpy")\n', "")
    ns = {"__name__": module.__name__ + "_python"}
    exec(compile(src, module.__file__, "exec"), ns)
    return ns


# -- alias table -----------------------------------------------------------------------------
def alias_weights() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(31)
    w = rng.random(3000) ** 2
    zeros = w.copy()
    zeros[rng.random(w.size) < 0.3] = 0.0
    return {
        "random": w,
        "zeros": zeros,
        "one huge": np.r_[np.ones(2000), 1e300, rng.random(500)],
        "1e-300": np.r_[np.full(1000, 1e-300), rng.random(1000), 0.0],
        "subnormal": np.array([1e-320, 3e-320, 0.0, 5e-324]),
        "single": np.array([0.7]),
        "two": np.array([1.0, 3.0]),
        "ties 1-4": rng.integers(1, 5, 4000).astype(float),
        "k/7": (np.arange(2100) % 7 + 1) / 7.0,
        "halves": np.tile([1.0, 3.0, 1.0, 1.0, 3.0, 3.0], 500),         # p = 0.5 or 1.5: exact ties
        "jitter": 1 + rng.random(3000) * 1e-13,
        "one heavy": np.r_[np.ones(3000), 2.0],
        "pareto": rng.pareto(0.7, 3000),
    }


def check_alias_parity(w: np.ndarray) -> None:
    """The compiled table is a valid table of w / sum(w) (to 1e-12 relative per index) and
    draws what the NumPy table draws (all but a tie or two)."""
    ref, got = AliasTable(w, kernels="numpy"), AliasTable(w, kernels="numba")
    assert got.kernels == "numba"
    q, alias = np.asarray(got.q), np.asarray(got.alias)
    assert np.all((q >= 0) & (q <= 1)) and np.all((alias >= 0) & (alias < w.size))
    assert np.all(w[alias[q < 1]] > 0), "a drawable alias points at a zero weight"
    want = ref.probabilities
    pmf = got.table_pmf()
    pos = want > 0
    assert np.all(pmf[~pos] == 0)
    np.testing.assert_allclose(pmf[pos], want[pos], rtol=1e-12, atol=0)
    u = np.random.default_rng(w.size).random(20_000)
    assert np.mean(got.sample(u) != ref.sample(u)) <= 1e-3


@pytest.mark.parametrize("name", list(alias_weights()))
def test_alias_kernel_matches_numpy(name):
    check_alias_parity(alias_weights()[name])


@pytest.mark.parametrize("n", [2**17 + 3, 400_000])
def test_alias_kernel_matches_numpy_packed(n):
    """Above 2^17 columns the table is packed (``alias_pack``): the same draws."""
    rng = np.random.default_rng(n)
    w = rng.exponential(size=n) ** 2
    w[rng.random(n) < 0.1] = 0.0
    check_alias_parity(w)
    ref, got = AliasTable(w, kernels="numpy"), AliasTable(w, kernels="numba")
    assert np.mean(got._packed != ref._packed) <= 1e-3          # q to the ulp: rarely a last bit


ALIAS_MUTANTS = {
    "finished heavy aliases itself": ("    alias[h] = h2\n", "    alias[h] = h\n"),
    "light deficit p, not 1 - p": ("y_hi, y_lo = _add(y_hi, y_lo, 1.0 - p)", "y_hi, y_lo = _add(y_hi, y_lo, p)"),
    "tie goes to the spent heavy": ("(y_hi - x_hi) + (y_lo - x_lo) >= 0.0:", "(y_hi - x_hi) + (y_lo - x_lo) > 0.0:"),
    "excess counted twice": ("(ph - 1.0) * f)", "(ph - 1.0))"),
}


@pytest.mark.parametrize("mutant", [None, *ALIAS_MUTANTS])
def test_alias_parity_fails_on_a_mutated_kernel(mutant, monkeypatch):
    ns = as_python(alias_kernel, *([ALIAS_MUTANTS[mutant]] if mutant else []))
    monkeypatch.setattr(alias_build, "load_kernel", lambda module, name: ns[name])
    cases = [alias_weights()[k] for k in ("random", "halves", "zeros")]
    if mutant is None:                                   # the control: the kernel's own source passes
        for w in cases:
            check_alias_parity(w)
        return
    with pytest.raises(AssertionError):
        for w in cases:
            check_alias_parity(w)


# -- light BVH -------------------------------------------------------------------------------
def bvh_scene(L: int, seed: int, kind: str = "random") -> dict:
    """Lights in boxes: a share emit all around, others one-sided (some two-sided) area
    lights; ``kind``: "ties" (every light twice, and lights on a lattice), "zero power"
    (a third with phi = 0), "facing up" (one-sided lights near z = 0 facing +z: points
    below are dead ends)."""
    rng = np.random.default_rng(seed)
    c = rng.uniform(-5, 5, (L, 3))
    if kind == "ties":
        c = np.repeat(np.round(c[: (L + 1) // 2]), 2, axis=0)[:L]
    e = rng.uniform(0, 0.5, (L, 3))
    w = rng.normal(size=(L, 3))
    sph = rng.random(L) < 0.4
    phi = rng.uniform(0.1, 2.0, L)
    if kind == "ties":
        e, w, sph, phi = (np.repeat(a[: (L + 1) // 2], 2, axis=0)[:L] for a in (e, w, sph, phi))
    if kind == "zero power":
        phi[rng.random(L) < 0.3] = 0.0
    if kind == "facing up":
        c[:, 2] *= 0.02
        w, sph = np.tile([0.0, 0.0, 1.0], (L, 1)), np.zeros(L, bool)
        return dict(lo=c - e * [1, 1, 0], hi=c + e * [1, 1, 0], w=w, cos_theta_o=np.ones(L), cos_theta_e=np.zeros(L),
                    phi=phi)
    return dict(lo=c - e, hi=c + e, w=w, cos_theta_o=np.where(sph, -1.0, 1.0), cos_theta_e=np.zeros(L), phi=phi,
                two_sided=~sph & (rng.random(L) < 0.3))


def bvh_points(scene: dict, N: int, seed: int) -> tuple:
    """Points: random, inside light boxes, at box centres (and at lights), a quarter
    without a normal; uniforms with exact halves and the ends of [0, 1)."""
    rng = np.random.default_rng(seed + 1)
    lo, hi = scene["lo"], scene["hi"]
    p = rng.uniform(-6, 6, (N, 3))
    k = rng.integers(0, len(lo), N)
    inside = rng.random(N) < 0.25
    p[inside] = (lo[k] + (hi[k] - lo[k]) * rng.random((N, 3)))[inside]
    centre = rng.random(N) < 0.05
    p[centre] = ((lo[k] + hi[k]) / 2)[centre]
    n = rng.normal(size=(N, 3))
    n[rng.random(N) < 0.25] = 0.0
    u = rng.random(N)
    u[:: 7] = 0.5
    u[1:: 11] = 0.0
    u[2:: 13] = np.nextafter(1.0, 0.0)
    return p, n, u


def check_bvh_parity(scene: dict, p, n, u) -> float:
    """The compiled walk picks the NumPy walk's light for the same uniform (all but a
    1e-3 share: a tie at a split rounds either way) with pmf to 1e-6 relative; pmf agrees
    for sampled and for arbitrary lights.  Returns the share of different picks."""
    ref, got = LightBVH(**scene), LightBVH(**scene, kernels="numba")
    j0, p0 = ref.sample(p, n, u)
    j1, p1 = got.sample(p, n, u)
    differ = float(np.mean(j0 != j1))
    assert differ <= 1e-3, differ
    same = j0 == j1
    np.testing.assert_allclose(p1[same], p0[same], rtol=1e-6, atol=0)
    jr = np.random.default_rng(len(u)).integers(-1, len(scene["phi"]), len(u))
    for j in (j0, jr):
        np.testing.assert_allclose(got.pmf(p, n, j), ref.pmf(p, n, j), rtol=1e-6, atol=0)
    return differ


BVH_CASES = [(2, 200, 0, "random"), (40, 2000, 1, "random"), (300, 5000, 2, "random"), (64, 3000, 3, "ties"),
             (50, 3000, 4, "zero power"), (80, 3000, 6, "facing up"), (1000, 20_000, 5, "random")]


@pytest.mark.parametrize("L, N, seed, kind", BVH_CASES)
def test_light_bvh_kernel_matches_numpy(L, N, seed, kind):
    scene = bvh_scene(L, seed, kind)
    check_bvh_parity(scene, *bvh_points(scene, N, seed))


def test_light_bvh_kernel_without_normals_and_one_light():
    scene = bvh_scene(30, 8)
    p, _, u = bvh_points(scene, 1000, 8)
    ref, got = LightBVH(**scene), LightBVH(**scene, kernels="numba")
    for a, b in zip(ref.sample(p, None, u), got.sample(p, None, u)):
        np.testing.assert_array_equal(a, b)
    one = {k: v[:1] for k, v in scene.items()}
    check_bvh_parity(one, p, np.zeros_like(p), u)


BVH_MUTANTS = {
    "children swapped": [("i0 = _importance(t, two, c, p", "i0 = _importance(t, two, c + 2, p"),
                         ("i1 = _importance(t, two, c + 1, p", "i1 = _importance(t, two, c, p"),
                         ("i0 = _importance(t, two, c + 2, p", "i0 = _importance(t, two, c + 1, p")],
    "no normal term": [("    if has_n[i]:\n", "    if False:\n")],
    "no orientation bound": [("cos_x = cos_w * cos_o + sin_w * sin_o", "cos_x = cos_w")],
    "no distance": [("imp /= d2", "imp /= 1.0")],
    "no bounding sphere": [("if dist2 < r2:", "if False:"), ("math.sqrt(max(1.0 - r2 / d2, 0.0))", "1.0")],
    "pmf follows the other child": [("if trail[jj[i], d]:", "if not trail[jj[i], d]:")],
    "pmf past a dead end": [("prob = prob * (1.0 - p0) * (1.0 if i1 > 0 else 0.0)", "prob = prob * (1.0 - p0)")],
    "u not rescaled": [("ui = min((ui - p0) / (pc if pc > 0 else 1.0), _ONE_MINUS_EPS)", "ui = ui")],
}


@pytest.mark.parametrize("mutant", [None, *BVH_MUTANTS])
def test_bvh_parity_fails_on_a_mutated_kernel(mutant, monkeypatch):
    ns = as_python(light_bvh_kernel, *BVH_MUTANTS.get(mutant, []))
    monkeypatch.setattr(LightBVH, "_compiled", staticmethod(lambda name: ns[name]))
    scenes = [bvh_scene(24, 11), bvh_scene(16, 12, "ties"), bvh_scene(20, 13, "facing up")]
    if mutant is None:                                   # the control: the kernel's own source passes
        for scene in scenes:
            check_bvh_parity(scene, *bvh_points(scene, 400, 11))
        return
    with pytest.raises(AssertionError):
        for scene in scenes:
            check_bvh_parity(scene, *bvh_points(scene, 400, 11))


def test_the_renderers_light_selection_takes_the_compiled_walk():
    """BVHSelection (light_selection="bvh") with kernels="numba": the same lights, triangles and
    probabilities as the default NumPy walk, lights at infinity included."""
    import copy

    from test_render_light_bvh import ENV, _floor_points, _lights

    sel = _lights(ENV).tree
    b = sel.tree.bounds
    fast = copy.copy(sel)
    fast.tree = LightBVH(b.lo, b.hi, b.w, b.cos_o, b.cos_e, b.phi, b.two, kernels="numba")
    p, n = _floor_points(3000, 7)
    u = np.random.default_rng(8).random(len(p))
    got, want = fast.sample(p, n, u), sel.sample(p, n, u)
    assert np.mean(got[0] != want[0]) <= 1e-3
    same = got[0] == want[0]
    np.testing.assert_array_equal(got[2][same], want[2][same])
    np.testing.assert_allclose(got[1][same], want[1][same], rtol=1e-6, atol=0)
    np.testing.assert_allclose(fast.pmf(p, n, want[0], want[2]), sel.pmf(p, n, want[0], want[2]), rtol=1e-6, atol=0)


def _in_a_forked_child(w, scene, p, n, u):
    return AliasTable(w, kernels="numba").q.sum(), LightBVH(**scene, kernels="numba").sample(p, n, u)[0]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fork")
def test_kernels_run_in_forked_workers():
    """Loaded in the parent, the serial kernels run in forked children (a prange kernel under
    Numba's OpenMP layer would hang there)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    w = np.random.default_rng(1).random(5000)
    scene = bvh_scene(50, 9)
    p, n, u = bvh_points(scene, 500, 9)
    want = _in_a_forked_child(w, scene, p, n, u)
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork")) as pool:
        futures = [pool.submit(_in_a_forked_child, w, scene, p, n, u) for _ in range(2)]
        for f in futures:
            got = f.result(timeout=120)
            assert got[0] == want[0] and np.array_equal(got[1], want[1])
