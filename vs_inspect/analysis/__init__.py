"""Derived views of a run: triangulated trajectories, epipolar sweeps."""
