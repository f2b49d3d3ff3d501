"""robolobe.plan (see DESIGN.md)."""
