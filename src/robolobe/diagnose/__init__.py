"""robolobe.diagnose (see DESIGN.md)."""
