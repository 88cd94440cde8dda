"""What a user reads says what things are: every `--help` shows each option's default, and no help text, policy
description, README line or user docs page names an internal issue number."""

from __future__ import annotations

import argparse
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from auv_mj.cli import COMMANDS, command_parser
from auv_mj.zoo.registry import POLICIES

ROOT = Path(__file__).resolve().parents[2]
ISSUE = re.compile(r"\bissues? \d+", re.IGNORECASE)
USER_PAGES = ("README.md", *(str(p.relative_to(ROOT)) for p in sorted((ROOT / "docs").glob("*.md"))),
              *(str(p.relative_to(ROOT)) for p in sorted((ROOT / "models").rglob("README.md"))))
"""The pages a user reads (docs/runs/ holds lab notebooks, not user pages)."""


def _parsers() -> Iterator[tuple[str, argparse.ArgumentParser]]:
    """Every subcommand's parser and the parsers of its own subcommands (`auv-mj plot trajectory`, ...)."""
    stack = [(f"auv-mj {name}", command_parser(name)) for name, _, _ in COMMANDS]
    while stack:
        prog, parser = stack.pop()
        yield prog, parser
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                stack.extend((f"{prog} {kind}", sub) for kind, sub in action.choices.items())


@pytest.fixture(scope="module")
def parsers() -> list[tuple[str, argparse.ArgumentParser]]:
    return list(_parsers())


def test_every_option_with_a_default_shows_it_in_help(parsers):
    hidden = []
    for prog, parser in parsers:
        formatter = parser._get_formatter()
        for action in parser._actions:
            default = action.default
            if (not action.option_strings or action.nargs == 0 or default is None or default is argparse.SUPPRESS
                    or action.help is argparse.SUPPRESS or (isinstance(default, list | tuple | dict) and not default)):
                continue  # no default to show: a flag, None, or a repeatable option's empty list
            text = " ".join(formatter._format_action(action).split())
            shown = {str(default), f"{default:g}" if isinstance(default, float) else str(default)}
            described = "default" in (action.help or "").lower()  # in the author's words: "(default: the shipped one)"
            if "default" not in text.lower() or not (described or any(value in text for value in shown)):
                hidden.append(f"{prog} {action.option_strings[-1]} (default {default!r}): {text}")
    assert not hidden, "\n".join(hidden)


def test_help_shows_eval_s_defaults(capsys):
    from auv_mj.cli import main

    with pytest.raises(SystemExit):
        main(["eval", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "(default: 0)" in text  # --seed
    assert re.search(r"--episodes \S+ episodes per task \(default: 10\)", text)


def test_no_help_text_names_an_issue_number(parsers):
    found = [f"{prog}: {m.group(0)}" for prog, parser in parsers for m in ISSUE.finditer(parser.format_help())]
    assert not found, found


def test_no_policy_description_names_an_issue_number():
    found = [f"{name}: {text}" for name, entry in POLICIES.items() for text in map(str, vars(entry).values())
             if ISSUE.search(text)]
    assert not found, found


@pytest.mark.parametrize("page", USER_PAGES)
def test_no_user_page_names_an_issue_number(page):
    found = [f"{page}:{n}: {line.strip()}" for n, line in enumerate((ROOT / page).read_text().splitlines(), 1)
             if ISSUE.search(line)]
    assert not found, "\n".join(found)
