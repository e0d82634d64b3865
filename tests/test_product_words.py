"""The product speaks of the product: no word of how it was developed (a numbered stop or issue,
"this session", held-out or tuning sets, a lab notebook) in the repository's text files or in
the --help of any command, and every config field's doc says in at most 200 characters what the
knob does."""

from __future__ import annotations

import argparse
import ast
import re
from pathlib import Path

import pytest

from vs_inspect.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
PROCESS_WORDS = re.compile(r"\bstops? \d+|\bstop-\d+|\bissues? #?\d+|this session|held[- ]out|"
                           r"tuning (?:set|scene)s?|lab notebook|README stop", re.IGNORECASE)
# what is scanned: the folders and files a user or a contributor reads
SCANNED = ("README.md", "BENCHMARKS.md", "Makefile", "pyproject.toml", "docs", "examples", "vs_inspect",
           "tests", ".ci")
TEXT_SUFFIXES = {".py", ".md", ".toml", ".txt", ".cfg", ".ini", ".yml", ".yaml", ".sh", ".json", ".html", ""}
SKIPPED_DIRS = {"__pycache__", ".cache", ".pytest_cache", "node_modules"}
# the few places allowed to match, each with why: (path relative to the repository, the match)
ALLOWED = {
    ("tests/test_product_words.py", None),  # this file lists the words it looks for
}
MAX_FIELD_DOC = 200  # characters of a config field's docstring


def _text_files():
    for name in SCANNED:
        path = ROOT / name
        if path.is_file():
            yield path
        elif path.is_dir():
            for p in sorted(path.rglob("*")):
                if p.is_file() and p.suffix in TEXT_SUFFIXES and not SKIPPED_DIRS & set(p.parts):
                    yield p


def _allowed(rel: str, match: str) -> bool:
    return (rel, None) in ALLOWED or (rel, match) in ALLOWED


def _findings(text: str, rel: str) -> list[str]:
    out = []
    for no, line in enumerate(text.splitlines(), 1):
        for m in PROCESS_WORDS.finditer(line):
            if not _allowed(rel, m.group(0)):
                out.append(f"{rel}:{no}: {m.group(0)!r} in {line.strip()[:120]!r}")
    return out


def test_no_development_process_words_in_the_tree():
    found = []
    for path in _text_files():
        try:
            text = path.read_text(encoding="utf-8")
        except (UnicodeDecodeError, OSError):
            continue  # not a text file after all
        found += _findings(text, path.relative_to(ROOT).as_posix())
    assert not found, f"{len(found)} development-process word(s):\n" + "\n".join(found[:60])


def _subparsers(parser: argparse.ArgumentParser):
    """(name, parser) of every command and subcommand under parser, depth first."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield name, sub
                yield from ((f"{name} {n}", s) for n, s in _subparsers(sub))


def test_no_development_process_words_in_any_help():
    parser = build_parser()
    helps = [("vs-inspect", parser.format_help())] + [(n, s.format_help()) for n, s in _subparsers(parser)]
    assert len(helps) > 10  # every command was reached
    found = [f"vs-inspect {name} --help: {f}" for name, text in helps for f in _findings(text, f"<{name}>")]
    assert not found, "\n".join(found)


def _dataclass_field_docs():
    """(where, field, its docstring) for every field of every dataclass in the package."""
    for path in sorted((ROOT / "vs_inspect").rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not isinstance(node, ast.ClassDef) or not any(
                    "dataclass" in ast.unparse(d) for d in node.decorator_list):
                continue
            for st, nxt in zip(node.body, node.body[1:]):
                if (isinstance(st, ast.AnnAssign) and isinstance(st.target, ast.Name)
                        and isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant)
                        and isinstance(nxt.value.value, str)):
                    yield f"{path.relative_to(ROOT).as_posix()}:{node.name}", st.target.id, nxt.value.value


def test_every_config_field_doc_says_what_the_knob_does_in_a_line_or_two():
    docs = list(_dataclass_field_docs())
    assert len(docs) > 100  # the config dataclasses were found
    long = [f"{where}.{name}: {len(doc)} characters" for where, name, doc in docs if len(doc) > MAX_FIELD_DOC]
    assert not long, "\n".join(long)


# the numbered examples are assembled, so that this file does not hold the words it forbids
@pytest.mark.parametrize("text, found", [("measured at stop " + "61", True), ("stops " + "43-45", True),
                                         ("issue " + "19's target", True), ("Issue #" + "7", True),
                                         ("held-out-2", True),
                                         ("this session", True), ("the tuning set", True),
                                         ("stop the run", False), ("the stop-loss", False), ("issues", False),
                                         ("fine-tuning", False)])
def test_the_words_it_looks_for(text, found):
    assert bool(PROCESS_WORDS.search(text)) == found
