"""The user docs as a contract (stop 37 QA): every command they show parses with the CLI as it
is, every option the CLI has is named in them, and the defaults they state are the CLI's.

tests/test_tutorial.py runs the tutorial's commands and compares what they print; the README's
tour and the other pages show commands that are not run here (they take minutes: simulations,
identifications), so this checks them against the parser: a renamed or removed option, or a
command that no longer exists, fails here. Synopsis lines (`[--seed N]`, `vr|bldc`, `...`) are
checked option by option.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import build_parser, subparsers

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: Fenced blocks that hold commands: ```sh, ```bash, or a bare ``` (the CLI synopses).
SHELL = ("```sh", "```bash", "```")
#: Marks of a synopsis line: optional parts, alternatives, placeholders.
SYNOPSIS = re.compile(r"[\[\]|]|\.\.\.|\(--")


def _tree(
    parser: argparse.ArgumentParser, path: tuple[str, ...] = ()
) -> dict[tuple[str, ...], argparse.ArgumentParser]:
    out = {}
    for name, child in subparsers(parser).items():
        out[(*path, name)] = child
        out.update(_tree(child, (*path, name)))
    return out


def blocks(text: str) -> list[str]:
    """The bodies of the page's fenced shell (or bare) blocks."""
    out: list[str] = []
    body: list[str] | None = None
    keep = False
    for line in text.splitlines():
        if body is None and line.strip().startswith("```"):
            body, keep = [], line.strip() in SHELL
        elif body is not None and line.strip() == "```":
            if keep:
                out.append("\n".join(body))
            body = None
        elif body is not None:
            body.append(line)
    return out


def doc_commands() -> list[tuple[str, str]]:
    """(page name, command line) of every torquemap command in the pages' code blocks."""
    found = []
    for page in PAGES:
        for block in blocks(page.read_text(encoding="utf-8")):
            body = re.sub(r"\\\n\s*", " ", block)  # continued lines
            previous = ""
            for raw in body.splitlines():
                line = raw.split(" #")[0].strip().removeprefix("$ ")
                line = line.removeprefix(".venv/bin/")
                if line.startswith("torquemap "):
                    previous = line
                    found.append((page.name, line))
                elif raw.startswith(" ") and previous and line.startswith("["):
                    # a synopsis continued on an indented line: its options are the command's
                    found[-1] = (page.name, f"{found[-1][1]} {line}")
                else:
                    previous = ""
    return found


def _command_path(
    words: list[str], tree: dict[tuple[str, ...], argparse.ArgumentParser]
) -> tuple[str, ...]:
    path: tuple[str, ...] = ()
    for word in words:
        if not path and word.startswith("-"):  # a top-level option: torquemap --quiet ...
            continue
        if (*path, word) not in tree:
            break
        path = (*path, word)
    return path


def test_the_docs_show_commands() -> None:
    commands = doc_commands()
    pages = {page for page, _ in commands}
    # the pages a new user reads first, each with its commands in a block
    assert {"README.md", "tutorial.md", "fleet.md", "rosbag.md", "arm.md", "odrive.md"} <= pages
    assert len(commands) >= 40


@pytest.mark.parametrize(("page", "line"), doc_commands())
def test_every_command_in_the_docs_is_one_the_cli_takes(page: str, line: str) -> None:
    parser = build_parser()
    tree = _tree(parser)
    words = shlex.split(line.split(" > ")[0])[1:]
    path = _command_path(words, tree)
    assert path, f"{page}: not a torquemap command: {line}"
    command = tree[path]
    # each option it names, spelled in full (argparse would take an abbreviation), is the
    # command's (or the top level's: --quiet)
    options = re.findall(r"(?<![\w-])--\[no-\]([a-z][\w-]*)|(?<![\w-])(--?[a-zA-Z][\w-]*)", line)
    for negated, name in options:
        for option in [f"--{negated}", f"--no-{negated}"] if negated else [name]:
            assert option in command._option_string_actions or (
                option in parser._option_string_actions
            ), f"{page}: `torquemap {' '.join(path)}` has no option {option}: {line}"
    for option, listed in re.findall(r"(--[a-z][\w-]*) \(?([\w.-]+(?:\|[\w.-]+)+)", line):
        choices = command._option_string_actions[option].choices
        if choices is not None:  # the alternatives a synopsis lists are the option's choices
            assert set(listed.split("|")) <= set(choices), f"{page}: {option} {listed}: {line}"
    if SYNOPSIS.search(line):  # a synopsis: placeholders and alternatives do not parse
        return
    with contextlib.redirect_stderr(io.StringIO()) as err:
        try:
            args = parser.parse_args(words)
        except SystemExit:
            pytest.fail(f"{page}: does not parse: {line}\n{err.getvalue()}")
    assert callable(args.handler), line


def test_every_option_is_named_in_the_docs() -> None:
    """An option a user can only find in --help is one the docs forgot (or a dead one)."""
    text = "\n".join(page.read_text(encoding="utf-8") for page in PAGES)
    missing = []
    for path, command in _tree(build_parser()).items():
        for action in command._actions:
            longs = [o for o in action.option_strings if o.startswith("--")]
            if not longs or isinstance(action, argparse._HelpAction):
                continue
            if "-o" in action.option_strings:
                continue  # -o is what the docs write for --output / --out
            if not any(re.search(rf"{re.escape(o)}(?![\w-])", text) for o in longs):
                missing.append(f"torquemap {' '.join(path)} {longs[0]}")
    assert not missing, "name these in the docs:\n" + "\n".join(missing)


def test_excite_defaults_are_the_documented_ones(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`excite`'s default period is the one docs/arm.md states (twice the slowest joint's swing
    over its range at its speed limit), the library's: before stop 37 the CLI fixed 20 s, so
    the Panda's path was 100 s where the docs (and `exciting_trajectory`) say 96 s, and a
    leg's 20 s where they say 2.9 s."""
    from test_robots_urdf import _robot_dir

    from torquemap.cli.main import main
    from torquemap.excite import exciting_trajectory
    from torquemap.io import read_table
    from torquemap.robot import load_robot

    robot = _robot_dir(tmp_path)
    out = tmp_path / "traj.csv"
    assert main(["--quiet", "excite", str(robot), "-o", str(out), "--rate", "50"]) == 0
    printed = capsys.readouterr().out
    cols = read_table(out)
    arm = load_robot(robot).arm
    want = exciting_trajectory(arm, rate=50.0)
    # the documented default: one traversal at full speed and one at a quarter, 5 periods,
    # the period twice the slowest joint's 2 pi A / v rounded up to 0.1 s
    lo, hi = arm.position_limits
    half = np.minimum(0.5 * (hi - lo) - 0.1 * (hi - lo), np.pi)
    period = np.ceil(10 * 2 * np.max(2 * np.pi * half / (0.7 * arm.velocity_limits))) / 10
    assert want.t[-1] == pytest.approx(5 * period)
    assert cols["t"][-1] == pytest.approx(want.t[-1])
    assert f", {want.t[-1]:.4g} s," in printed
    for k, name in enumerate(want.joint_names):
        np.testing.assert_allclose(cols[f"q_{name}"], want.q[:, k], atol=1e-9)


@pytest.mark.parametrize("out", ["first.csv", "few.csv", "second.json", "second.parquet"])
def test_transfer_checks_its_output_before_any_work(
    out: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """docs/safety.md: every command refuses, before any work, an output that is one of its
    inputs or whose suffix is not what it writes (CSV). `linearize transfer` did neither: `-o
    FIRST.csv` replaced the first joint's characterisation with the transferred rows (exit 0),
    and `-o x.json` or `.parquet` held CSV text that `linearize build` cannot read."""
    from torquemap.cli.main import main

    for name in ("first.toml", "first.csv", "second.toml", "few.csv"):
        (tmp_path / name).write_text(f"{name}\n")  # never read: the outputs are checked first
    before = {p.name: p.read_text() for p in tmp_path.iterdir()}
    argv = ["linearize", "transfer", *(str(tmp_path / n) for n in before), "-o"]
    assert main([*argv, str(tmp_path / out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"torquemap: error: {tmp_path / out}: "), err
    assert ("is also an input" if out in before else "does not match what is written (.csv)") in err
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == before


def test_excite_checks_its_output_before_the_search(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from test_robots_urdf import _robot_dir

    from torquemap.cli.main import main

    robot = _robot_dir(tmp_path)
    # before, the search ran first (seconds on an arm) and the refusal was a log reader's
    # "unknown table format (use .csv or .parquet)"; robot.toml was refused only by its suffix
    for out in ("traj.json", "robot.toml"):
        assert main(["--quiet", "excite", str(robot), "-o", str(tmp_path / out)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "does not match what is written (.csv or" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["robot.toml", "two_link.urdf"]


def test_build_tables_signature_in_the_docs() -> None:
    """docs/linearize.md shows build_tables' signature: every keyword, with its default."""
    import inspect

    from torquemap.linearize.tables import build_tables

    text = (ROOT / "docs" / "linearize.md").read_text(encoding="utf-8")
    shown = re.search(r"```python\n(build_tables\(.*?\))\n    -> TableSet", text, re.S)
    assert shown, "the signature block of docs/linearize.md"
    documented = dict(re.findall(r"(\w+)=([^,)\s]+)", shown.group(1)))
    actual = {
        name: repr(p.default).replace("'", '"')
        for name, p in inspect.signature(build_tables).parameters.items()
        if p.kind is p.KEYWORD_ONLY
    }
    assert documented == actual


def test_fleet_drift_checks_its_output_before_the_trends(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # before, the trends were computed and printed, then the write refused ".json"
    from torquemap.cli.main import main

    assert main(["fleet", "drift", str(tmp_path), "-o", str(tmp_path / "drift.json")]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1
    assert "does not match what is written (.csv or .parquet)" in captured.err


def inline_commands() -> list[tuple[str, str]]:
    """(page name, text) of the torquemap commands the pages quote inline (`torquemap ...`)."""
    found = []
    for page in PAGES:
        text = re.sub(r"\s*\n\s*", " ", page.read_text(encoding="utf-8"))
        found += [(page.name, m) for m in re.findall(r"`(torquemap [^`]+)`", text)]
    return found


def test_every_option_quoted_inline_is_the_commands() -> None:
    parser = build_parser()
    tree = _tree(parser)
    bad = []
    quoted = inline_commands()
    assert len(quoted) > 50
    for page, line in quoted:
        words = line.replace("(", " ").replace(")", " ").split()
        path = _command_path(words[1:], tree)
        if not path:
            continue  # prose such as `torquemap ... | head`
        command = tree[path]
        for option in re.findall(r"(?<![\w-])(--[a-zA-Z][\w-]*)", line):
            if option not in command._option_string_actions | parser._option_string_actions:
                bad.append(f"{page}: `{line}`: no option {option}")
    assert not bad, "\n".join(bad)
