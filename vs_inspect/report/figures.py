"""2D report figures with matplotlib (Agg), one function per figure key, each taking ReportData,
an output path, dpi, formats and size, and writing the figure in each requested format (PNG at
the given dpi, PDF, SVG); nothing is computed here. The report (build.py) calls them by key:

    curve_panels.py   landscapes, transfer, three_view: curves over candidate offsets
    sync_overview.py  pair_graph, timeline
    frame_panels.py   epipolar, mosaic: drawn over video frames

Their printed style (sizes, fonts, colours, formats) is figure_style.py; sizes, notes and saving
are figure_layout.py.
"""

from __future__ import annotations

from .curve_panels import landscapes, three_view, transfer  # noqa: F401 - the figures by key
from .frame_panels import epipolar, mosaic  # noqa: F401
from .sync_overview import pair_graph, timeline  # noqa: F401
