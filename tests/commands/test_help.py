"""Every subcommand's --help: each default said once, never "(default: None)", no default on a
required option or a switch, an Examples epilog naming the command, no literal %%."""

from __future__ import annotations

import argparse
import re

import pytest

from vs_inspect.cli import build_parser, main

PARSER = build_parser()
SUBCOMMANDS = next(a for a in PARSER._actions if isinstance(a, argparse._SubParsersAction)).choices


def _option_blocks(text: str) -> dict[str, str]:
    """{first flag: its help text joined into one line} from argparse's option listing."""
    out: dict[str, str] = {}
    key = None
    for line in text.splitlines():
        m = re.match(r"^  (-{1,2}[\w-]+|[a-z_]+)\b(.*)$", line)
        if m:
            key = m.group(1)
            out[key] = m.group(2).strip()
        elif key and line.startswith(" " * 6) and line.strip():
            out[key] += " " + line.strip()
        elif not line.strip() or not line.startswith(" "):
            key = None
    return out


@pytest.mark.parametrize("name", sorted(SUBCOMMANDS))
def test_help_of_every_subcommand(name, capsys):
    assert main([name, "--help"]) == 0
    text = capsys.readouterr().out
    assert "%%" not in text
    assert "(default: None)" not in text
    blocks = _option_blocks(text.split("Examples:")[0])
    assert blocks, name
    sub = SUBCOMMANDS[name]
    required = {s for a in sub._actions if a.required for s in a.option_strings}
    switches = {s for a in sub._actions if a.nargs == 0 for s in a.option_strings}
    for flag, help_text in blocks.items():
        assert help_text.lower().count("default") <= 1, (name, flag, help_text)
        if flag in required:
            assert "(default:" not in help_text, (name, flag, help_text)
        if flag in switches:  # a switch may say what happens without it, never "False"
            assert not re.search(r"\(default: (False|True)\)", help_text), (name, flag, help_text)
    examples = text.split("Examples:", 1)
    assert len(examples) == 2, f"{name}: no Examples section"
    assert f"vs-inspect {name}" in examples[1]


def test_negated_filter_says_what_it_does(capsys):
    main(["sync", "--help"])
    blocks = _option_blocks(capsys.readouterr().out)
    assert blocks["--no-spurious-filter"].startswith("turn off the spurious-pair filter")
