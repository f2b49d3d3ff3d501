"""robolobe.sld (see DESIGN.md)."""
