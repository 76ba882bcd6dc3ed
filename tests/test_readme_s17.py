"""Session 17 README check: every CLI option says what it does in ``--help``.

The README points newcomers at ``hvacfmu <command> --help`` (e.g. ``hvacfmu generate --help`` for the emulator's
options); an option listed there without a description leaves them to guess what ``--seed`` or ``--weeks`` means.
"""

import argparse

from hvacfmu.cli.commands import build_parser


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(action.choices)


def test_every_option_of_every_command_has_a_help_text():
    missing = [
        f"hvacfmu {name} {'/'.join(a.option_strings)}"
        for name, sub in _subparsers(build_parser()).items()
        for a in sub._actions
        if a.option_strings and not a.help
    ]
    assert not missing, f"options without a help text: {missing}"


def test_demo_help_names_the_defaults_the_readme_quotes(capsys):
    # README, "The demo": `hvacfmu demo [--out DIR] [--weeks 51] [--seed 0] [--horizon N]`
    sub = _subparsers(build_parser())["demo"]
    text = sub.format_help()
    for option, default in (("--weeks", "51"), ("--seed", "0"), ("--out", "hvacfmu-demo")):
        action = next(a for a in sub._actions if option in a.option_strings)
        assert str(action.default) == default
        assert option in text and f"default {default}" in (action.help or "").replace("./", "")
