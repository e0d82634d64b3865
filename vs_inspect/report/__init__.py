"""Report images: ReportData (data.py, computed by analysis/report_data.py) drawn by figures.py
(matplotlib) and scene3d.py (pyvista, off-screen), collected in index.html (build.py)."""
