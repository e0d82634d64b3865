"""Derived views of a run: what the recording and the report show, and the diagnosis of a run."""
