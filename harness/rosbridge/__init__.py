"""harness.rosbridge (see ARCHITECTURE.md)."""
