"""robolobe.robots (see DESIGN.md)."""
