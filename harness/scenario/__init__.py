"""harness.scenario (see ARCHITECTURE.md)."""
