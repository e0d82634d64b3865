"""Every command's and sub-command's --help (bench stage0 clips, calib convert, ...): each default
said once, never "(default: None)", no default on a required option or a switch, an Examples
epilog naming the command, no literal %%."""

from __future__ import annotations

import argparse
import re

import pytest

from vs_inspect.cli import build_parser, main


def _commands(parser: argparse.ArgumentParser, prefix: str = "") -> dict[str, argparse.ArgumentParser]:
    """{"sync": parser, "bench": parser, "bench stage0": parser, ...}: every command, depth first."""
    out = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                out[f"{prefix}{name}"] = sub
                out.update(_commands(sub, f"{prefix}{name} "))
    return out


SUBCOMMANDS = _commands(build_parser())


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
    assert main([*name.split(), "--help"]) == 0
    text = capsys.readouterr().out
    assert "%%" not in text
    assert "(default: None)" not in text
    blocks = _option_blocks(text.split("Examples:")[0])
    assert blocks and "-h" in blocks, name
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


def test_every_benchmark_is_a_bench_sub_command_with_an_example():
    benches = [n for n in SUBCOMMANDS if n.startswith("bench ")]
    assert {"bench accuracy", "bench stage0", "bench stage0 caliscope", "bench stage0 clips",
            "bench stage0 rendered", "bench stage0 speed", "bench timing", "bench energy", "bench scale",
            "bench drone", "bench drift", "bench people", "bench rules", "bench recording", "bench interrupts"} == set(benches)
    assert not [n for n in SUBCOMMANDS if n.startswith("bench-")]


def test_negated_filter_says_what_it_does(capsys):
    main(["sync", "--help"])
    blocks = _option_blocks(capsys.readouterr().out)
    assert blocks["--no-spurious-filter"].startswith("turn off the spurious-pair filter")
