"""Pure geometry: no I/O, no logging set-up, no rerun. Each idea once, shape-checked:

epipolar     F between two cameras at their moments, residuals, epipolar lines, line clipping
timing       frame brackets of a video's clock, pose and intrinsics interpolation
sampling     a video's tracks and camera at any local times (the paper's "video b at t − Δ")
triangulate  two-view DLT and the one filter for the points kept
offsets      the candidate time offsets of every pair: overlap, range and per-video windows
two_view     F and E from correspondences, focal from F, relative pose, Sampson distances
camera_model intrinsics fitted to another image size, OpenCV's and COLMAP's lenses and their inverses
"""
