"""The experiment figures follow the figure rules (issue 15): every axes that shows data has
an x and a y label, no axes carries more than ``MAX_LINES`` lines, a legend label keeps its
colour across the axes of a figure, and tick labels do not overlap.  The figure builders
are called on small inputs (seconds), not through the experiments' ``main``.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("matplotlib")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import to_hex  # noqa: E402
from matplotlib.container import ErrorbarContainer  # noqa: E402
from vrlab.lab.plots import overlapping_tick_labels  # noqa: E402

MAX_LINES = 6


def _caplines(ax) -> set:
    caps = set()
    for c in ax.containers:
        if isinstance(c, ErrorbarContainer):
            caps.update(id(line) for line in c.lines[1])
    return caps


def data_lines(ax) -> list:
    """The Line2D objects of ``ax`` except error-bar caps."""
    caps = _caplines(ax)
    return [line for line in ax.lines if id(line) not in caps]


def is_colorbar(ax) -> bool:
    return getattr(ax, "_colorbar", None) is not None


def shows_data(ax) -> bool:
    """Lines, markers, bars or patches: an axes whose x and y positions mean something (an
    axis-free image panel and a colour bar do not count)."""
    if is_colorbar(ax) or not ax.get_visible():
        return False
    return bool(data_lines(ax) or ax.collections or ax.patches)


def _colour(handle):
    """The colour a legend handle shows (a line's colour, a patch's or a marker set's face)."""
    for get in ("get_color", "get_facecolor", "get_edgecolor"):
        if hasattr(handle, get):
            c = getattr(handle, get)()
            if not isinstance(c, str) and np.ndim(c) == 2:
                if not len(c):
                    continue
                c = c[0]
            try:
                return to_hex(c, keep_alpha=False)
            except (TypeError, ValueError):
                continue
    return None


def legend_colours(ax) -> dict:
    leg = ax.get_legend()
    if leg is None:
        return {}
    out = {}
    for handle, text in zip(leg.legend_handles, leg.get_texts()):
        if isinstance(handle, ErrorbarContainer):
            handle = handle.lines[0]
        colour = _colour(handle)
        if colour is not None:
            out[text.get_text()] = colour
    return out


def problems(fig) -> list[str]:
    """What breaks the rules in ``fig`` (empty: none)."""
    out, seen = [], {}
    for k, ax in enumerate(fig.axes):
        if not shows_data(ax):
            continue
        name = f"axes {k} ({ax.get_title()!r})"
        labels = (ax.get_xlabel(), ax.get_ylabel()) + ((ax.get_zlabel(),) if hasattr(ax, "get_zlabel") else ())
        if not all(s.strip() for s in labels):
            out.append(f"{name}: unlabelled axis {labels}")
        if len(data_lines(ax)) > MAX_LINES:
            out.append(f"{name}: {len(data_lines(ax))} lines")
        for label, colour in legend_colours(ax).items():
            if seen.setdefault(label, colour) != colour:
                out.append(f"{name}: legend {label!r} is {colour} here, {seen[label]} elsewhere")
    out += [f"overlapping tick labels {a!r} / {b!r}" for a, b in overlapping_tick_labels(fig)]
    return out


def _check(fig):
    try:
        assert problems(fig) == []
    finally:
        plt.close(fig)


# -- the checker itself can fail ---------------------------------------------------------
def test_checker_flags_bad_figures():
    fig, axes = plt.subplots(1, 2)
    for k in range(7):
        axes[0].plot([0, 1], [k, k + 1], label=f"m{k}")
    axes[0].legend()
    axes[1].plot([0, 1], [0, 1], color="red", label="m0")
    axes[1].legend()
    axes[1].set_xlabel("x (m)")
    found = problems(fig)
    plt.close(fig)
    assert any("7 lines" in p for p in found)
    assert any("unlabelled" in p and "axes 0" in p for p in found)
    assert any("unlabelled" in p and "axes 1" in p for p in found)
    assert any("'m0'" in p for p in found)

    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot(range(40), range(40))
    ax.set_xticks(range(40), [f"tick {k}" for k in range(40)])
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    found = problems(fig)
    plt.close(fig)
    assert found and all(p.startswith("overlapping tick labels") for p in found)


def test_checker_ignores_axis_free_images_and_colour_bars():
    fig, ax = plt.subplots()
    im = ax.imshow(np.eye(4))
    ax.set_xticks([])
    ax.set_yticks([])
    fig.colorbar(im, ax=ax, label="value (1)")
    assert problems(fig) == []
    plt.close(fig)


# -- the figures of the experiment modules ---------------------------------------------
def test_importance_sampling_figures():
    from vrlab import lab
    from vrlab.estimators import MonteCarlo
    from vrlab.experiments import importance_sampling as m
    from vrlab.integrands import catalogue

    _check(m.densities_figure())
    sin, step = catalogue.get("sin"), catalogue.get("step-x2")
    df = pd.concat([lab.run([(f"{f.name} {k}", MonteCarlo(d, probe=False)) for k, d in f.techniques.items()],
                            [f], [16, 32, 64], 5, rng=1) for f in (sin, step)], ignore_index=True)
    summary = lab.summarize(df)
    _check(m.convergence_figure(summary, lab.fit_slopes(summary)))


def test_control_variates_figure():
    from vrlab.experiments import control_variates as m

    table = m.correlation_sweep(np.linspace(-1, 1, 9), 200, 3, 0)
    _check(m.sweep_figure(table, m.crossings(table)))


def test_discrete_sampling_figures():
    from vrlab.experiments import discrete_sampling as m

    _check(m.example_figure(m.example_table()))
    t = m.timings([4, 6], 256, 1, 0)
    _check(m.timings_figure(t))


def test_metropolis_hastings_figures():
    from vrlab.experiments import metropolis_hastings as m

    res = m.run_configs(64, 4, seed=1)
    _check(m.tv_figure(res))
    _check(m.histograms_figure(res))


def test_ris_variance_figure():
    from vrlab.experiments import ris as m

    table = m.variance_sweep((1, 4), 500, 3)
    _check(m.variance_figure(table, m.limits(), m.selection_histograms((1, 4), n=500)))


def test_sampling_patterns_figures():
    from vrlab.experiments import _sampling_patterns_figures as figs
    from vrlab.experiments import sampling_patterns as m

    _check(figs.patterns_figure(m.pattern_points(16)))
    _check(figs.discrepancy_figure(m.discrepancy_table([16, 32], reps=1)))
    summary, slopes = m.convergence([16, 32, 64], 4)
    _check(figs.convergence_figure(summary, slopes))


def test_environment_lighting_figures(tmp_path):
    from vrlab.distributions import EnvironmentMap
    from vrlab.experiments import environment_lighting as m
    paths = m.write_scenes(tmp_path, (40, 30))
    t, imgs, ref = m.compare(paths, 4, 8)
    env = EnvironmentMap(m.sky_image(16, 32))
    d, _, dimg = m.delta_check(paths, 4)
    for fig in (m.renders_figure(t, imgs, ref), m.map_figure(env, m.sun_fractions(env, 1000)),
                m.delta_figure(dimg, d)):
        _check(fig)
