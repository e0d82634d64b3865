"""index.html: the figures with the numbers behind them (offsets, decisions, errors vs truth)."""

from __future__ import annotations

import html
import math
from pathlib import Path

from .. import palette
from .data import ReportData
from .figure_style import fmt_px


def _s(x: float | None, digits: int = 4, sign: bool = True) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    return f"{x:+.{digits}f}" if sign else f"{x:.{digits}f}"


def _null_status(headline: str, full: str) -> str:
    """A null's status cell: its reason in a few words, the whole reason unfolded on a click."""
    e = html.escape
    more = f"<details><summary>in full</summary>{e(full)}</details>" if full and full != headline else ""
    return f"unresolved: {e(headline)}{more}"


CSS = """
body { font-family: system-ui, sans-serif; margin: 24px; max-width: 1700px; color: #222; }
table { border-collapse: collapse; margin: 8px 0 24px 0; font-size: 14px; }
th, td { border: 1px solid #ccc; padding: 4px 8px; text-align: right; }
th { background: #f2f2f2; } td.l { text-align: left; }
tr.acc td.d { color: ACC; font-weight: bold; } tr.rej td.d { color: REJ; font-weight: bold; }
figure { margin: 12px 0 32px 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 14px; color: #444; margin-top: 4px; }
.notes li { color: #8a5a00; }
""".replace("ACC", palette.hex_of(palette.ACCEPTED)).replace("REJ", palette.hex_of(palette.REJECTED))


def write_index(data: ReportData, images: dict[str, tuple[str, str]], path: Path) -> Path:
    """images: {key: (file name, caption)} in display order."""
    e = html.escape
    gt = data.gt_offsets_s
    errs = data.errors_ms()
    frames = data.errors_frames() if data.videos else {}
    out = ["<!doctype html>", "<html><head><meta charset='utf-8'>",
           "<title>vs-inspect report</title>", f"<style>{CSS}</style></head><body>",
           "<h1>vs-inspect report</h1>",
           f"<p class='source'>source: <code>{e(data.source)}</code></p>",
           f"<p>reference video: <b>{e(data.reference)}</b> (offset 0). A frame at local time τ of "
           "video v shows global time τ + offset(v); Δ<sub>ab</sub> = offset(b) − offset(a).</p>"]

    short = bool(data.label_legend())  # the figures draw videos by short names: say which
    out.append("<h2>Offsets</h2><table id='offsets'><tr><th>video</th>"
               + ("<th>in the figures</th>" if short else "") + "<th>offset [s]</th>"
               "<th>± [s]</th>" + ("<th>true [s]</th><th>error [ms]</th><th>error [frames]</th>" if gt else "")
               + "<th>status</th></tr>")
    ref_gt = gt.get(data.reference, 0.0) if gt else 0.0
    for v in data.names or list(data.offsets_s):
        off = data.offsets_s.get(v)
        row = f"<tr><td class='l'>{e(v)}</td>" + (f"<td class='l'>{e(data.label(v))}</td>" if short else "") + \
              f"<td>{_s(off)}</td>" \
              f"<td>{_s(data.uncertainty_s.get(v), 4, False)}</td>"
        if gt:
            row += (f"<td>{_s(gt[v] - ref_gt) if v in gt else '—'}</td><td>{_s(errs.get(v), 1, False)}</td>"
                    f"<td>{_s(frames.get(v), 2, False)}</td>")
        status = e("reference" if v == data.reference else "synchronized") if off is not None else (
            _null_status(data.unresolved_headline.get(v, ""), data.unresolved.get(v, "")))
        out.append(row + f"<td class='l'>{status}</td></tr>")
    out.append("</table>")
    resolved = [x for x in errs.values() if x is not None]
    if resolved:
        out.append(f"<p id='summary'>error against the truth over {len(resolved)} videos: mean "
                   f"{sum(resolved) / len(resolved):.1f} ms, max {max(resolved):.1f} ms.</p>")

    acc = sum(p.accepted for p in data.pairs)
    out.append(f"<h2>Pairs ({acc} accepted, {len(data.pairs) - acc} rejected)</h2>"
               "<table id='pairs'><tr><th>a</th><th>b</th><th>decision</th><th>Δ chosen [s]</th>"
               "<th>± [s]</th><th>Δ solved [s]</th>" + ("<th>Δ true [s]</th><th>error [ms]</th>" if gt else "")
               + "<th>track pairs</th><th>contrast</th><th>reason</th></tr>")
    for p in data.pairs:
        row = (f"<tr class='{'acc' if p.accepted else 'rej'}'><td class='l'>{e(p.a)}</td>"
               f"<td class='l'>{e(p.b)}</td><td class='d l'>{'accepted' if p.accepted else 'rejected'}</td>"
               f"<td>{_s(p.chosen_offset_s)}</td><td>{_s(p.uncertainty_s, 4, False)}</td>"
               f"<td>{_s(p.solved_offset_s)}</td>")
        if gt:
            row += f"<td>{_s(p.true_offset_s)}</td><td>{_s(p.error_ms, 1, False)}</td>"
        row += (f"<td>{p.num_track_pairs}</td><td>{p.contrast:.3f}</td>"
                f"<td class='l'>{e(p.reason)}</td></tr>")
        out.append(row)
    out.append("</table>")

    if data.epipolar is not None:
        ep = data.epipolar
        out.append("<h2>Epipolar check</h2><table id='epipolar'><tr><th>pair</th><th>frame of a</th>"
                   "<th>Δ [s]</th><th>median distance to the line [px]</th></tr>")
        best = "chosen" if ep.accepted else "best of a rejected pair"
        for label, st in (("wrong", ep.wrong), (best, ep.chosen)):
            out.append(f"<tr><td class='l'>{e(ep.a)} – {e(ep.b)} ({label})</td><td>{ep.frame_a}</td>"
                       f"<td>{_s(st.offset_s, 3)}</td><td>{e(fmt_px(st.median_distance_px))}</td></tr>")
        out.append("</table>")

    out.append("<h2>Figures</h2>")
    for key, (name, caption) in images.items():
        out.append(f"<figure id='fig-{e(key)}'><img src='{e(name)}' alt='{e(key)}'>"
                   f"<figcaption>{e(caption)}</figcaption></figure>")
    if data.notes:
        out.append("<h2>Not shown</h2><ul class='notes'>" +
                   "".join(f"<li>{e(n)}</li>" for n in data.notes) + "</ul>")
    out.append("</body></html>")
    path.write_text("\n".join(out), encoding="utf-8")
    return path
