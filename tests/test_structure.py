"""The package's shape (issue 23, items 5 and 6): no import circle, the render CLI's modules depend
on shared settings rather than on each other, one execution layer (pool initialiser, pickle check,
executor parallelism in vrlab.execution), and modules of about 400 lines at most."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

import vrlab

PKG = Path(vrlab.__file__).parent
#: circles allowed: none (the scene loader's two, scene<->scene_checks and builtin<->loader, went
#: with the scene-element rebuild of issue 20)
KNOWN: set[frozenset[str]] = set()


def _modules() -> dict[str, Path]:
    out = {}
    for p in PKG.rglob("*.py"):
        parts = list(p.relative_to(PKG.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


def _imports(mods: dict[str, Path]) -> dict[str, set[str]]:
    """Every vrlab module each module imports, at module level or inside a function."""
    graph = {}
    for name, path in mods.items():
        is_pkg = path.name == "__init__.py"
        deps = set()
        for node in ast.walk(ast.parse(path.read_text())):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = name.split(".") if is_pkg else name.split(".")[:-1]
                if node.level:
                    base = base[: len(base) - (node.level - 1)]
                    prefix = ".".join(base + ([node.module] if node.module else []))
                else:
                    prefix = node.module or ""
                targets = [f"{prefix}.{a.name}" if f"{prefix}.{a.name}" in mods else prefix for a in node.names]
            for t in targets:
                while t and t not in mods:
                    t = t.rpartition(".")[0]
                if t.startswith("vrlab") and t != name and not name.startswith(t + "."):
                    deps.add(t)
        graph[name] = deps
    return graph


def _circles(graph: dict[str, set[str]]) -> list[frozenset]:
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(frozenset(comp))
    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_circle():
    circles = [sorted(c) for c in _circles(_imports(_modules())) if c not in KNOWN]
    assert not circles, circles


def test_the_circle_finder_finds_one():
    """The mutation: cli_compare importing cli_render again is a circle."""
    graph = _imports(_modules())
    graph["vrlab.cli_compare"] = graph["vrlab.cli_compare"] | {"vrlab.cli_render"}
    assert frozenset({"vrlab.cli_compare", "vrlab.cli_render"}) in _circles(graph)


#: The layer table of docs/design.md ("Layers"), lowest first: a module imports (at module level or
#: inside a function) only modules of its own layer, of lower layers, or shared helpers.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("point sets", ("vrlab.points",)),
    ("warps", ("vrlab.distributions",)),
    ("integrands", ("vrlab.integrands",)),
    ("estimators", ("vrlab.estimators", "vrlab.estimate")),
    ("execution", ("vrlab.execution",)),
    ("lab", ("vrlab.lab",)),
    ("renderer", ("vrlab.render",)),
    ("tools", ("vrlab.testing", "vrlab.bench")),
    ("experiments", ("vrlab.experiments", "vrlab.notebooks")),
    ("command line", ("vrlab.cli*", "vrlab.demo", "vrlab._demo_samplers", "vrlab.__main__")),
)
#: shared helpers: every layer may import them; they import only each other
SHARED = ("vrlab.checks", "vrlab._rng", "vrlab._vec", "vrlab._lazy", "vrlab._alloc", "vrlab.limits", "vrlab.colour",
          "vrlab.metrics", "vrlab.significance", "vrlab.kernels")
#: the package root re-exports a few names (``vrlab.Estimate``, ``vrlab.AliasTable``) and stands above the table
ROOT = "vrlab"


def _layer(module: str) -> int | None:
    """The layer's index in ``LAYERS`` (-1 for a shared helper), None for a module the table misses."""
    from fnmatch import fnmatchcase

    if module in SHARED:
        return -1
    for k, (_, packages) in enumerate(LAYERS):
        if any(fnmatchcase(module, p) or module.startswith(p + ".") for p in packages):
            return k
    return None


def _layer_violations(graph: dict[str, set[str]]) -> list[str]:
    """Every import that goes up the table (or from a shared helper into a layer), and every module
    the table does not place."""
    out = []
    for name in sorted(graph):
        if name == ROOT:
            continue
        here = _layer(name)
        if here is None:
            out.append(f"{name}: in no layer of the table")
            continue
        for dep in sorted(graph[name]):
            there = _layer(dep)
            if there is None or there > here or (here == -1 and there != -1):
                where = "a shared helper" if here == -1 else LAYERS[here][0]
                to = "no layer" if there is None else "the shared helpers" if there == -1 else LAYERS[there][0]
                out.append(f"{name} ({where}) imports {dep} ({to})")
    return out


def test_imports_only_go_down_the_layer_table():
    """docs/design.md's layer table holds with no exception, lazy imports included."""
    bad = _layer_violations(_imports(_modules()))
    assert not bad, "\n".join(bad)


def test_the_layer_check_finds_an_up_arrow():
    """The mutations: mc_variance borrowing the harness's charts again (the old exception), the
    lab's trust flags importing vrlab.testing, a shared helper importing a layer, and a module the
    table misses are each reported."""
    graph = _imports(_modules())
    assert not _layer_violations(graph)
    for name, dep in (("vrlab.integrands.theory", "vrlab.testing.charts"), ("vrlab.lab.trust", "vrlab.testing"),
                      ("vrlab.checks", "vrlab.points"), ("vrlab.distributions.charts", "vrlab.integrands")):
        mutated = {**graph, name: graph[name] | {dep}}
        assert [v for v in _layer_violations(mutated) if v.startswith(name + " ") and dep in v], (name, dep)
    assert _layer_violations({**graph, "vrlab.stray": set()}) == ["vrlab.stray: in no layer of the table"]


def test_compare_and_gradient_depend_on_shared_settings_not_on_cli_render():
    graph = _imports(_modules())
    for name in ("vrlab.cli_compare", "vrlab.cli_gradient"):
        assert "vrlab.cli_render" not in graph[name] and "vrlab.cli_render_settings" in graph[name], name


def test_settings_are_built_once_as_one_object(tmp_path):
    import argparse

    from vrlab.cli import build_parser
    from vrlab.cli_render_settings import RenderSettings, settings_from_args

    args = build_parser().parse_args(["render", "furnace", "--spp", "4", "--width", "6", "--height", "4",
                                      "--pixel-sampler", "sobol", "-o", str(tmp_path / "x.npy")])
    assert isinstance(args, argparse.Namespace)
    s = settings_from_args(args)
    assert isinstance(s, RenderSettings) and s.spp == 4 and (s.scene.sensor.width, s.scene.sensor.height) == (6, 4)
    assert s.sampling()["points"] == "sobol" and s.output.name == "x.npy"


def test_modules_of_about_400_lines_at_most():
    long = {str(p.relative_to(PKG)): n for p in PKG.rglob("*.py") if (n := len(p.read_text().splitlines())) > 400}
    assert not long, long


def test_one_execution_layer():
    """The pool initialiser runs in the local pools' processes (the allocator tuning with it);
    the pickle check and an executor's parallelism are vrlab.execution's."""
    from concurrent.futures import ThreadPoolExecutor

    from vrlab import execution

    got = dict(execution.run_units(_worker_state, [()] * 4, workers=2))
    assert all(parent_set and tuned for parent_set, tuned in got.values()), got
    with pytest.raises(TypeError, match="cannot go"):
        execution.check_picklable(lambda x: x, None, "cannot go", "define it at module level")
    assert execution.check_picklable([1, 2], None, "x", "y")
    with ThreadPoolExecutor(3) as pool:
        assert execution.parallelism(pool) == 3
    assert not execution.is_dask(None) and not execution.is_dask(ThreadPoolExecutor(1))


def _worker_state():
    import threading

    import vrlab._alloc as alloc

    watching = any(t.name == "vrlab-watch-parent" for t in threading.enumerate())
    return watching, bool(alloc._done)


def test_one_definition_of_luminance_and_light_selections():
    """The luminance weights and the light-selection names each live in one place."""
    import re

    weights = re.compile(r"[\[(,]\s*0\.2126")
    where = [str(p.relative_to(PKG)) for p in PKG.rglob("*.py") if weights.search(p.read_text())]
    assert where == ["colour.py"], where
    names = re.compile(r"""["']uniform["'],\s*["']power["'],\s*["']bvh["']""")
    where = [str(p.relative_to(PKG)) for p in PKG.rglob("*.py") if names.search(p.read_text())]
    assert where == ["limits.py"], where
