"""harness.sim (see ARCHITECTURE.md)."""
