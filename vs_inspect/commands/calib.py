"""vs-inspect calib convert: a camera calibration from one tool's format to another's."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import add_force_option
from ..errors import InputError


def register(sub) -> None:
    from ..io.calib import FORMATS
    p = sub.add_parser("calib", help="convert camera calibrations between tools' formats",
                       description="Camera calibration files of motion-capture and 3D tools.")
    cs = p.add_subparsers(dest="calib_command", metavar="ACTION", required=True)
    formats = "; ".join(f"{f.name}: {f.summary}" for f in FORMATS.values())
    c = cs.add_parser(
        "convert", help="convert a calibration file or folder to another format",
        description="Read IN (format from the path: a COLMAP or EasyMocap folder, .json, .toml, "
                    ".qca.txt, .xcp, intri.yml/extri.yml) and write OUT in the format its name "
                    f"says, or --to. Formats: {formats}. Units: files in millimetres are read "
                    "into metres and written back in millimetres; cameras keep their names.")
    c.add_argument("input", type=Path, metavar="IN", help="calibration file or folder to read")
    c.add_argument("output", type=Path, metavar="OUT", help="file or folder to write")
    c.add_argument("--to", choices=sorted(FORMATS), default=None,
                   help="output format (default: from OUT's name; needed for folders and to pick "
                        "among the TOML dialects, .toml alone means pose2sim)")
    c.add_argument("--size", nargs=2, type=int, metavar=("WIDTH", "HEIGHT"), default=None,
                   help="image size for cameras whose file does not store one (EasyMocap)")
    add_force_option(c, "OUT")
    c.set_defaults(func=run)
    from . import _help
    _help.apply(c, "calib convert")


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace
    from ..io.calib import format_for_output, read_named, write

    fmt = format_for_output(args.output, args.to)
    if args.output.exists() and not args.force:
        if not (args.output.is_dir() and not any(args.output.iterdir())):
            raise InputError(f"OUT {args.output} exists; give --force to replace it")
    if args.output.resolve() == args.input.resolve():
        raise InputError("IN and OUT are the same path")
    cams = read_named(args.input)
    if args.size:
        w, h = args.size
        if w < 1 or h < 1:
            raise InputError(f"--size must be positive, got {w} {h}")
        cams = {k: c if c.size is not None else replace(c, size=(w, h)) for k, c in cams.items()}
    files = write(cams, args.output, fmt.name)
    print(f"wrote {len(cams)} cameras ({', '.join(cams)}) as {fmt.name}: "
          + ", ".join(str(f) for f in files))
    return 0
