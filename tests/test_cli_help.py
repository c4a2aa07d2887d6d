"""CLI help: every command described with an example, every argument explained."""

from __future__ import annotations

import argparse
import shlex

import pytest

from torquemap.cli.helptext import described
from torquemap.cli.main import build_parser, commands, subparsers


def _tree(
    parser: argparse.ArgumentParser, path: str = "torquemap"
) -> list[tuple[str, argparse.ArgumentParser]]:
    out = []
    for name, child in subparsers(parser).items():
        out.append((f"{path} {name}", child))
        out.extend(_tree(child, f"{path} {name}"))
    return out


def undocumented(parser: argparse.ArgumentParser) -> list[str]:
    """What lacks a description, an example, or a help text, one line each."""
    missing = []
    for path, command in _tree(parser):
        if not (command.description or "").strip():
            missing.append(f"{path}: no description")
        if f"\n  {path} " not in f"\n{command.epilog or ''}":
            missing.append(f"{path}: no example ('  {path} ...') in its epilog")
        if not issubclass(command.formatter_class, argparse.RawDescriptionHelpFormatter):
            missing.append(f"{path}: epilog not kept as written (RawDescriptionHelpFormatter)")
    for path, command in [("torquemap", parser), *_tree(parser)]:
        for action in command._actions:
            if isinstance(action, argparse._HelpAction | argparse._VersionAction):
                continue
            if isinstance(action, argparse._SubParsersAction):
                listed = {c.dest for c in action._choices_actions if (c.help or "").strip()}
                for name in subparsers(command):
                    if name not in listed:
                        missing.append(f"{path} {name}: no help in the command list")
            if not (action.help or "").strip():
                name = "/".join(action.option_strings) or action.metavar or action.dest
                missing.append(f"{path}: argument {name} has no help text")
    return missing


def test_every_command_and_argument_is_documented() -> None:
    missing = undocumented(build_parser())
    assert not missing, "document these (cli/helptext.py `described`):\n" + "\n".join(missing)


def test_every_example_parses() -> None:
    # the examples use the options as they are: a renamed or removed option fails here
    parser = build_parser()
    examples = [
        line.strip()
        for _, command in [("torquemap", parser), *_tree(parser)]
        for line in (command.epilog or "").splitlines()[1:]
    ]
    assert len(examples) > 20
    for example in examples:
        words = shlex.split(example.split(" > ")[0])  # the shell's redirection is not torquemap's
        assert words[0] == "torquemap", example
        try:
            args = parser.parse_args(words[1:])
        except SystemExit:
            pytest.fail(f"example does not parse: {example}")
        assert callable(args.handler), example


def test_the_check_finds_what_is_missing() -> None:
    parser = argparse.ArgumentParser(prog="torquemap")
    sub = parser.add_subparsers(dest="command", help="the command")
    good = sub.add_parser("good", help="a good one", **described("Does.", ["torquemap good x"]))
    good.add_argument("x", help="the x")
    bad = sub.add_parser("bad", epilog="torquemap bad")
    bad.add_argument("--y")
    assert undocumented(parser) == [
        "torquemap bad: no description",
        "torquemap bad: no example ('  torquemap bad ...') in its epilog",
        "torquemap bad: epilog not kept as written (RawDescriptionHelpFormatter)",
        "torquemap bad: no help in the command list",
        "torquemap bad: argument --y has no help text",
    ]


def test_quiet_is_everywhere() -> None:
    for command in commands(build_parser()):
        assert "--quiet" in command._option_string_actions, command.prog
