"""Derived views of a run: triangulated trajectories, epipolar sweeps, what the recording and the
report show, and the diagnosis of a run."""
