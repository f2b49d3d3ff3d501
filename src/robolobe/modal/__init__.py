"""robolobe.modal (see DESIGN.md)."""
