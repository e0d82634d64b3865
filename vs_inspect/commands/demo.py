"""vs-inspect demo: the main job on the built-in default input, offsets printed next to the truth."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..io.bundle import read_bundle, write_bundle
from ..io.result import result_to_dict, write_json_atomic
from ..synth.cues import CueSceneConfig, make_cue_scene
from ..sync.config import SyncConfig
from ..sync.run import sync_bundle
from ._common import offsets_table
from ._record import add_record_options, describe, open_sink


def register(sub) -> None:
    p = sub.add_parser("demo", help="run on the built-in synthetic scene and compare with the truth",
                       description="Generates the default synthetic scene (cached in OUT), "
                                   "synchronizes it and prints estimated against true offsets.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="output folder")
    add_record_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    out = Path(args.out)
    bundle_dir = out / "bundle"
    if not (bundle_dir / "bundle.json").is_file():
        print("demo input: the default cue-level synthetic scene (7 cameras, 2 moving, 1 variable "
              "frame rate, 0.8 px noise, 25 % wrong track pairs, 0.5° pose error, one all-wrong pair)")
        write_bundle(make_cue_scene(CueSceneConfig()).bundle, bundle_dir, overwrite=True)
    else:
        print(f"demo input: cached scene in {bundle_dir}")
    bundle = read_bundle(bundle_dir)
    with open_sink(args, out) as sink:
        result = sync_bundle(bundle, SyncConfig(), sink=sink)
        data = result_to_dict(result, {"gt_offsets_s": bundle.gt_offsets_s})
        sink.run_summary(data)
        path = write_json_atomic(data, out / "result.json")
    print(offsets_table(result.offsets_s, result.uncertainty_s, bundle.gt_offsets_s,
                        result.reference, result.unresolved_reason))
    for p in result.pairs:
        if not p.decision.accepted:
            print(f"rejected {p.a}__{p.b}: {p.decision.reason}")
    print(f"wrote {path}")
    if describe(sink):
        print(describe(sink))
    return 0
