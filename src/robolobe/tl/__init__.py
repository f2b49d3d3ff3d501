"""robolobe.tl (see DESIGN.md)."""
