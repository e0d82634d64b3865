"""Pure geometry: no I/O, no logging set-up, no rerun."""
