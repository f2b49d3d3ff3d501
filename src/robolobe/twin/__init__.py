"""robolobe.twin (see DESIGN.md)."""
