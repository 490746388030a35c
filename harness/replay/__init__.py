"""harness.replay (see ARCHITECTURE.md)."""
