"""`vs-inspect view`: a command of the CLI, which names a missing recording and says when there is
no display to show the viewer on (opening at the front pair's Δ is checked with the real viewer
in tests/record/test_screenshots.py)."""

from __future__ import annotations

from vs_inspect.cli import main


def test_view_is_a_command_and_names_what_is_missing(tmp_path, capsys, monkeypatch):
    assert main(["view", "--help"]) == 0
    assert "front pair" in capsys.readouterr().out
    assert main(["view", str(tmp_path / "none.rrd")]) == 2
    assert f"{tmp_path / 'none.rrd'}: no such recording file" in capsys.readouterr().err
