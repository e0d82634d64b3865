"""How every command's --help reads: one formatter (a default shown once, never "None" or for a
switch) and an Examples epilog per command. cli.build_parser applies both to every subcommand."""

from __future__ import annotations

import argparse
import textwrap

EXAMPLES: dict[str, list[tuple[str, str]]] = {
    "bench": [("vs-inspect bench accuracy --quick", "a few minutes: a small subset of the accuracy tables"),
              ("vs-inspect bench stage0 clips", "the VisualSync clips through the whole pipeline"),
              ("vs-inspect bench timing --reference", "end-to-end time at 720p against the 3-minute target")],
    "bench accuracy": [("vs-inspect bench accuracy --quick", "a few minutes: a small subset, tables printed"),
                       ("vs-inspect bench accuracy --only cue/easy --json rows.json", "one dataset, rows as JSON")],
    "bench stage0": [("vs-inspect bench stage0 clips --scenes blenderbox", "one scene of the VisualSync clips"),
                     ("vs-inspect bench stage0 rendered --set seeds-10-21 --workdir /tmp/scenes",
                      "12 rendered scenes whose cameras share a view, estimated cameras")],
    "bench stage0 caliscope": [("vs-inspect bench stage0 caliscope --trials 3 --cameras estimated",
                                "3 random cuts of the 4 webcams, cameras estimated from the videos"),
                               ("vs-inspect bench stage0 caliscope --trials 6 --seed 1 --cameras board",
                                "cameras from the ChArUco board in the cut videos")],
    "bench stage0 clips": [("vs-inspect bench stage0 clips", "the 4 scenes of the VisualSync clips"),
                           ("vs-inspect bench stage0 clips --scenes fencing1 --workdir /tmp/clips",
                            "one scene; its run folder kept for `vs-inspect report`")],
    "bench stage0 rendered": [("vs-inspect bench stage0 rendered --cameras calibration",
                               "3 rendered scenes with their exact calibration, track pairs judged"),
                              ("vs-inspect bench stage0 rendered --scenes demo a60_c4m1_s12 --sync-args '--max-side 480'",
                               "two named scenes with a sync option")],
    "bench stage0 speed": [("vs-inspect bench stage0 speed", "4 x 10 s of 720p with the calibration, seconds per step"),
                           ("vs-inspect bench stage0 speed --cameras estimated --seconds 5", "estimated cameras, 5 s")],
    "bench timing": [("vs-inspect bench timing --reference",
                      "4 x 10 s 720p rendered videos through sync (estimated cameras and with the "
                      "calibration) against the 3-minute target, with the 480x360 reference"),
                     ("vs-inspect bench timing --width 160 --height 120 --seconds 2",
                      "a tiny scene: the table in about a minute")],
    "bench energy": [("vs-inspect bench energy --reference-offsets 11",
                      "speed of the landscape against plain numpy (run on 11 offsets, scaled to 201)")],
    "bench scale": [("vs-inspect bench scale --cameras 8 16 --pairs all knn:4", "local against Ray on small rigs"),
                    ("vs-inspect bench scale --engines local --cameras 64 --pairs knn:8", "one engine, one selection")],
    "bench drone": [("vs-inspect bench drone ../shared/data/drone_tracking_dataset3",
                     "per-camera shift and rate errors on the drone dataset")],
    "bench drift": [("vs-inspect bench drift --seeds 5",
                     "--drift against constant offsets on cue scenes whose clocks drift ±200 ppm"),
                    ("vs-inspect bench drift --drift-ppm 500 --seconds 60", "larger drift on longer scenes")],
    "bench people": [("vs-inspect bench people --scenes pan160906 --workdir /tmp/people",
                      "people as correspondences on one scene, its run folder kept in /tmp/people")],
    "bench rules": [("vs-inspect bench rules --scratch /tmp/rules --markdown rules.md",
                     "every set; a stopped run resumes from what /tmp/rules keeps"),
                    ("vs-inspect bench rules --scratch /tmp/rules --sets clips --rules margin transfer",
                     "two rules on the VisualSync clips")],
    "bench recording": [("vs-inspect bench recording demo", "the demo scene's recordings: size and write time"),
                        ("vs-inspect bench recording budget --out /tmp/rrd",
                         "4 x 10 s 720p videos with every frame and mask recorded, files kept in /tmp/rrd")],
    "bench interrupts": [("vs-inspect bench interrupts --workdir /tmp/vs_interrupts --moments 10 --repeats 3",
                          "SIGINT and SIGTERM at 10 moments of every long command, three times over"),
                         ("vs-inspect bench interrupts --workdir /tmp/vs_interrupts --moments 3 --repeats 1 --only report",
                          "a quick look at report alone")],
    "calib": [("vs-inspect calib convert Calib.qca.txt Calib.toml",
               "a Qualisys calibration as Pose2Sim's TOML"),
              ("vs-inspect calib convert out/run/cameras.json calibration.toml --to anipose",
               "the cameras a run used, for anipose")],
    "calib convert": [("vs-inspect calib convert Calib.qca.txt Calib.toml",
                       "a Qualisys calibration as Pose2Sim's TOML"),
                      ("vs-inspect calib convert sparse/0 easymocap_calib --to easymocap",
                       "a COLMAP model as EasyMocap's intri.yml and extri.yml"),
                      ("vs-inspect calib convert out/run/cameras.json calibration.toml --to anipose",
                       "the cameras a run used, for anipose")],
    "calibrate-board": [(("vs-inspect calibrate-board cam0.mp4 cam1.mp4 --board charuco.toml "
                          "--out calib.json"), "the rig's cameras; then sync --calib calib.json")],
    "cues": [("vs-inspect cues cam0.mp4 cam1.mp4 cam2.mp4 --calib calib.json --out bundle",
              "Stage 0 only: a cue bundle to sync later with --bundle")],
    "demo": [("vs-inspect demo", "render (once) and synchronize the built-in scene into out/demo"),
             ("vs-inspect demo --true-cues-only --out out/demo", "skip the videos' Stage 0 run"),
             ("vs-inspect report out/demo --out out/demo-report", "then its figures")],
    "eval": [("vs-inspect eval out/run --gt scene/gt.json", "A@100, A@500 and per-video errors")],
    "export": [("vs-inspect export out/run --offsets out/run/offsets.csv",
                "each video's offset in seconds and in its own frames, and its frames in the "
                "common span"),
               ("vs-inspect export out/run --trimmed out/run/trimmed",
                "every video cut to the common time span, for Pose2Sim, anipose or a NeRF trainer"),
               ("vs-inspect export out/run --mosaic out/run/mosaic.mp4",
                "all inputs side by side on the global timeline")],
    "import-drone": [("vs-inspect import-drone ../shared/data/drone_tracking_dataset3 --out drone",
                      "a pose-free cue bundle with gt.json")],
    "import-visualsync": [("vs-inspect import-visualsync visualsync_out --out bundle",
                           "a cue bundle from CoTracker / VGGT / filtered-pair outputs")],
    "inspect": [("vs-inspect inspect run.rrd", "offsets, decisions, causes and suspects"),
                ("vs-inspect inspect run.rrd --gt scene/gt.json --pair cam0 cam2",
                 "with errors against the truth and one pair's minima")],
    "report": [("vs-inspect report out/run --out out/run-report", "from a run folder"),
               ("vs-inspect report run.rrd --out report --format png,pdf --dpi 300",
                "from a recording alone, as PNG (300 dpi) and PDF, a page wide"),
               ("vs-inspect report run.rrd --out report --format pdf,svg --size column",
                "for a paper's column: 3.5 in wide, its text 7-9 pt"),
               ("vs-inspect report out/run --out report --gt scene/gt.json",
                "errors against the truth in the figures")],
    "sync": [("vs-inspect sync cam0.mp4 cam1.mp4 cam2.mp4 --calib calib.json --out out/run",
              "the whole pipeline on videos"),
             ("vs-inspect sync --bundle scene/bundle --out out/run --gt scene/gt.json",
              "Stage 1 + 2 on a cue bundle, errors against the truth"),
             ("vs-inspect sync --bundle drone --out out/drone --drift",
              "clock drift per video; a pose-free bundle (import-drone) from its tracks alone"),
             ("vs-inspect sync cams/*.mp4 --calib calib.json --out out/rig --engine ray --pairs knn:8",
              "a large rig: Stage 0 per video and Stage 1 per pair as Ray tasks"),
             ("vs-inspect sync --config out/run/config.json --bundle scene/bundle --out out/again --force",
              "repeat a run with its saved settings")],
    "view": [("vs-inspect view recordings/take1-*.rrd", "the viewer at the front pair's chosen Δ"),
             ("vs-inspect view run.rrd --pair cam0 cam2", "at another pair's Δ")],
    "synth-cues": [("vs-inspect synth-cues --out synth", "a cue-level scene with gt.json"),
                   ("vs-inspect sync --bundle synth --out out/synth --gt synth/gt.json", "then sync it")],
    "synth-video": [("vs-inspect synth-video --out scene --cameras 3 --seconds 4",
                     "videos, calibration.json, gt.json and the true bundle")],
}


def examples_epilog(command: str) -> str | None:
    rows = EXAMPLES.get(command)
    if not rows:
        return None
    lines = ["Examples:"]
    for cmd, what in rows:
        lines.append(f"  {cmd}")
        lines += textwrap.wrap(what, 76, initial_indent="      ", subsequent_indent="      ")
    return "\n".join(lines)


class HelpFormatter(argparse.HelpFormatter):
    """A default shown once: not when the help already says it, not for a required option, a
    switch or an unset (None) default. Text with line breaks (an epilog of examples or a layout)
    is printed as written; a single paragraph is wrapped."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        d = action.default
        if ("default" in text.lower() or action.required or d is None or d is argparse.SUPPRESS
                or isinstance(d, bool) or action.nargs == 0 or not action.option_strings):
            return text
        return text + " (default: %(default)s)"

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        if "\n" in text:
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


def apply(parser: argparse.ArgumentParser, command: str) -> None:
    """The formatter and the Examples epilog on one subcommand's parser (an existing epilog, such
    as a layout description, is kept above the examples)."""
    parser.formatter_class = HelpFormatter
    ex = examples_epilog(command)
    if ex:
        parser.epilog = f"{parser.epilog.rstrip()}\n\n{ex}" if parser.epilog else ex
