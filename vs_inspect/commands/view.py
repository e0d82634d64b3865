"""vs-inspect view: open a recording in the rerun viewer with its cursor at the front pair's Δ."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from ..errors import InputError, VsInspectError


def register(sub) -> None:
    p = sub.add_parser("view", help="open a recording (.rrd) in the rerun viewer at the front pair's Δ",
                       description="Opens a recording in the native rerun viewer (the one already "
                                   "listening on --port, else a new one) with the time cursor on "
                                   "offset_ms at the chosen Δ of the pair in front (failed pairs "
                                   "first), where its epipolar lines meet the points. `rerun FILE` "
                                   "opens at the start of the search range instead: a recording "
                                   "cannot tell the viewer where its cursor starts.")
    p.add_argument("rrd", type=Path, help="a .rrd written by vs-inspect sync/demo")
    p.add_argument("--pair", nargs=2, metavar=("A", "B"), help="put the cursor at this pair's Δ instead")
    p.add_argument("--at", type=int, metavar="MS", help="put the cursor here (ms on offset_ms) instead")
    p.add_argument("--port", type=int, default=9876, help="the viewer's port (a running viewer is reused)")
    p.set_defaults(func=run)


class ViewerUnavailable(VsInspectError):
    """No viewer could be shown (no display, or the viewer did not start)."""


def run(args: argparse.Namespace) -> int:
    from ..io.recording import read_recording
    from ..record.native_viewer import rerun_executable
    from ..record.viewer import front_offset_ms, front_pair, open_recording

    rec = read_recording(args.rrd)  # a missing or unreadable file fails here, naming it
    pair = tuple(args.pair) if args.pair else None
    if pair is not None and rec.result is not None and rec.result.pair(*pair) is None:
        known = ", ".join(f"{p.a} {p.b}" for p in rec.result.pairs)
        raise InputError(f"--pair {pair[0]} {pair[1]}: no such pair in {args.rrd} (pairs: {known or 'none'})")
    at = args.at if args.at is not None else front_offset_ms(rec, pair)
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ViewerUnavailable("no display to show the viewer on (DISPLAY is not set); copy the recording "
                                "to a machine with one and run `vs-inspect view` there")
    exe = rerun_executable()
    if exe is None:
        raise ViewerUnavailable("no rerun viewer found (install rerun-sdk)")
    from rerun.experimental import ViewerClient
    try:
        client = ViewerClient.connect(f"rerun+http://127.0.0.1:{args.port}/proxy")
        client.get_state()
    except Exception:  # noqa: BLE001 - none listening there: start one that outlives this command
        client = ViewerClient.spawn(port=args.port, hide_welcome_screen=True, detach_process=True,
                                    executable_path=str(exe))
    _, at = open_recording(client, args.rrd, pair, at)
    who = pair or front_pair(rec)
    where = (f"offset_ms = {at} ({who[0]}→{who[1]}'s {'chosen' if args.at is None else 'given'} Δ)"
             if at is not None and who else "as it opens (no pair offset was searched)")
    print(f"opened {args.rrd} in the rerun viewer on port {args.port}, cursor at {where}")
    return 0
