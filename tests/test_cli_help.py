"""Every option of every ``vrlab`` subcommand has help text that says what it does.

The walk goes through ``vrlab.cli.build_parser()`` and each subparser.  An option fails when
its help is missing, hidden (``argparse.SUPPRESS``) or only a default note such as
"(default: mis-power)"; a subcommand fails without its one-line help; an option whose
metavar hides its choices (``--strategy NAME``) must name every choice in its help.
"""
from __future__ import annotations

import argparse
import re

import pytest

from vrlab.cli import build_parser, main


def _parsers(parser: argparse.ArgumentParser, path: str | None = None):
    path = parser.prog if path is None else path
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _parsers(sub, f"{path} {name}")


def _name(action: argparse.Action) -> str:
    return "/".join(action.option_strings) or action.metavar or action.dest


def _words(text: str) -> list[str]:
    """The words of a help text outside its "(default: ...)" notes and %-placeholders."""
    text = re.sub(r"\(default:[^)]*\)", " ", text)
    return re.findall(r"[A-Za-z]{2,}", text.replace("%(default)s", " "))


def undocumented(parser: argparse.ArgumentParser) -> list[str]:
    """``"vrlab render --strategy: why"`` for every option or subcommand of ``parser`` (and its
    subparsers) whose help text is missing or says nothing."""
    bad = []
    for path, p in _parsers(parser):
        for action in p._actions:
            where = f"{path} {_name(action)}"
            text = action.help
            if text is None or text == argparse.SUPPRESS:
                bad.append(f"{where}: no help text")
                continue
            if len(_words(text)) < 2:
                bad.append(f"{where}: help {text!r} says nothing beyond its default")
            if isinstance(action, argparse._SubParsersAction):   # add_parser(help=...) lists a subcommand
                helps = {c.dest: c.help for c in action._choices_actions}
                for name in action.choices:
                    if not helps.get(name) or len(_words(helps[name])) < 2:
                        bad.append(f"{path} {name}: subcommand without help text")
            elif action.choices and action.metavar is not None:      # the usage line hides the choices
                missing = [c for c in action.choices if not re.search(rf"(?<![\w-]){re.escape(c)}(?![\w-])", text)]
                if missing:
                    bad.append(f"{where}: help does not name the choices {missing}")
    return bad


def test_every_option_has_help_text():
    assert undocumented(build_parser()) == []


def test_the_walk_reaches_every_subcommand_and_option():
    paths = {path: p for path, p in _parsers(build_parser())}
    assert {"vrlab", "vrlab demo", "vrlab lab", "vrlab render", "vrlab bench"} <= set(paths)
    options = {s for a in paths["vrlab render"]._actions for s in a.option_strings}
    assert {"--strategy", "--pixel-sampler", "--light-selection", "--seed", "--list", "--export", "--to"} <= options


def test_the_walk_catches_options_without_help():
    parser = argparse.ArgumentParser(prog="x")
    sub = parser.add_subparsers(dest="command", help="the subcommand to run")
    render = sub.add_parser("render")                      # no help= for the subcommand
    render.add_argument("--strategy", choices=["a", "b"], metavar="NAME", help="the sampling strategy, a")
    render.add_argument("--seed", help="(default: 0)")
    render.add_argument("--hidden", help=argparse.SUPPRESS)
    render.add_argument("--bare")
    render.add_argument("--ok", help="a documented option")
    found = "\n".join(undocumented(parser))
    for name in ("x render:", "--strategy: help does not name the choices ['b']", "--seed: help",
                 "--hidden: no help", "--bare: no help"):
        assert name in found, (name, found)
    assert "--ok" not in found


@pytest.mark.parametrize("argv", [["--help"], ["demo", "--help"], ["lab", "--help"], ["render", "--help"],
                                  ["bench", "--help"]])
def test_help_prints_and_exits_0(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: vrlab") and "exit status" in out


def test_render_help_explains_the_strategies_and_keeps_flag_names_whole(capsys):
    from vrlab.cli_render import PIXEL_SAMPLERS
    from vrlab.render.presets import PRESETS

    with pytest.raises(SystemExit):
        main(["render", "--help"])
    out = capsys.readouterr().out
    for name in (*PRESETS, *PIXEL_SAMPLERS, "power", "--export", "--to"):
        assert f"{name}:" in out or f"{name} " in out, name
    assert "--light-\n" not in out and "mis-\n" not in out      # not broken at a hyphen


def test_every_strategy_and_pixel_sampler_has_a_description():
    from vrlab.cli_render import PIXEL_SAMPLER_HELP, PIXEL_SAMPLERS
    from vrlab.render.presets import PRESETS, preset_help

    assert set(preset_help()) == set(PRESETS) and all(preset_help().values())
    assert set(PIXEL_SAMPLER_HELP) == set(PIXEL_SAMPLERS)


def test_gradient_domain_flags_have_help():
    """--gradient-domain and its flags are listed; the flags that need it say so, --reconstruct
    names l2 and l1 and the files -o writes are named."""
    render = next(p for path, p in _parsers(build_parser()) if path == "vrlab render")
    helps = {s: a.help for a in render._actions for s in a.option_strings}
    for flag in ("--reconstruct", "--alpha", "--independent"):
        assert "with --gradient-domain" in helps[flag], flag
    assert "l2:" in helps["--reconstruct"] and "l1:" in helps["--reconstruct"]
    assert all(name in helps["--gradient-domain"] for name in ("OUT_primal", "OUT_dx", "OUT_dy", "OUT_panels.png"))
    assert undocumented(build_parser()) == []


def _strategy_help() -> str:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    rend = sub.choices["render"]
    return next(a.help for a in rend._actions if "--strategy" in a.option_strings)


def test_render_help_gives_each_strategy_its_bias_from_the_registry(monkeypatch):
    """``vrlab render --help`` names each strategy with its recipe's bias status, read from the
    registry when the parser is built (a recipe whose bias changes shows the new one)."""
    from dataclasses import replace

    from vrlab.estimators import recipes, registry as reg

    text = _strategy_help()
    for name, r in recipes("render").items():
        assert f"{name}: {r.render_help} [{r.bias}]" in text, name
    table = dict(reg._REGISTRY)
    table["cv"] = replace(table["cv"], bias="consistent")
    monkeypatch.setattr(reg, "_REGISTRY", table)
    assert "[consistent]" in _strategy_help() and "[consistent]" not in text


def test_notebooks_help_counts_the_notebooks_it_writes(tmp_path, capsys):
    """The count in ``vrlab notebooks --help`` is the number of notebooks the command writes."""
    from vrlab.experiments import list_notebooks

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    description = " ".join(sub.choices["notebooks"].description.split())
    n = len(list_notebooks())
    assert f"Copy the {n} lecture notebooks" in description, description
    assert main(["notebooks", str(tmp_path / "nb")]) == 0
    assert len(list((tmp_path / "nb").glob("*.ipynb"))) == n and f"wrote {n} notebooks" in capsys.readouterr().out


def test_demo_help_states_the_budget_from_its_one_place(monkeypatch):
    """``vrlab demo --help`` states the time budget of vrlab.cli.DEMO_BUDGET_S (which
    benchmarks/bench_demo.py measures against), not a typed-in measurement: changing the
    budget changes the help."""
    import vrlab.cli as cli

    def quick_help():
        sub = next(a for a in cli.build_parser()._actions if isinstance(a, argparse._SubParsersAction))
        return next(a.help for a in sub.choices["demo"]._actions if "--quick" in a.option_strings)

    text = quick_help()
    assert f"under {cli.DEMO_BUDGET_S['quick']:g} s" in text and f"under {cli.DEMO_BUDGET_S['full'] / 60:g} min" in text
    assert "bench_demo.py" in text
    monkeypatch.setattr(cli, "DEMO_BUDGET_S", {"quick": 7.0, "full": 300.0})
    assert "under 7 s" in quick_help() and "under 5 min" in quick_help()
