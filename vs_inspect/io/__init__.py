"""Reading and writing files: cue bundles, results."""
