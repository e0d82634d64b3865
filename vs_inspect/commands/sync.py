"""vs-inspect sync: cue bundle (or videos) -> OUT/result.json and a table of offsets."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..errors import InputError
from ..io.bundle import read_bundle
from ..io.result import result_to_dict, run_result_from_dict, write_json_atomic
from ..sync.config import config_to_dict
from ..sync.run import sync_bundle
from ._common import add_sync_options, offsets_table, sync_config_from_args
from ._record import add_record_options, describe, open_sink


def register(sub) -> None:
    p = sub.add_parser("sync", help="synchronize videos or a cue bundle",
                       description="Estimate one time offset per video. Input is a cue bundle "
                                   "(--bundle DIR) or video files. Writes OUT/result.json.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("videos", nargs="*", help="video files or image folders (alternative to --bundle)")
    p.add_argument("--bundle", type=Path, help="cue bundle folder (see DESIGN.md, format v1)")
    p.add_argument("--out", type=Path, required=True, help="output folder for result.json")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    add_sync_options(p)
    add_record_options(p)
    from .cues import add_cue_options
    add_cue_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    cfg = sync_config_from_args(args)
    if args.bundle and args.videos:
        raise InputError("give either --bundle or video files, not both")
    if not args.bundle:
        if not args.videos:
            raise InputError("nothing to synchronize: give --bundle DIR or video files")
        from .cues import sync_videos
        return sync_videos(args, cfg)
    t0 = time.perf_counter()
    bundle = read_bundle(args.bundle)
    with open_sink(args, args.out, progress=not args.no_progress) as sink:
        result = sync_bundle(bundle, cfg, sink=sink, progress=not args.no_progress)
        data = result_to_dict(result, {"config": config_to_dict(cfg), "input": {"bundle": str(args.bundle)}})
        data["timings_s"]["total_s"] = round(time.perf_counter() - t0, 4)
        if bundle.gt_offsets_s:
            data["gt_offsets_s"] = bundle.gt_offsets_s
        sink.run_summary(run_result_from_dict(data))
        path = write_json_atomic(data, Path(args.out) / "result.json")
    if describe(sink):
        print(describe(sink))
    print(offsets_table(result.offsets_s, result.uncertainty_s, bundle.gt_offsets_s,
                        result.reference, result.unresolved_reason))
    acc = sum(p.decision.accepted for p in result.pairs)
    print(f"pairs: {acc} accepted, {len(result.pairs) - acc} rejected; wrote {path}")
    resolved = sum(v is not None for v in result.offsets_s.values())
    return 0 if resolved > 1 or len(result.offsets_s) == 1 else 2
