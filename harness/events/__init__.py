"""harness.events (see ARCHITECTURE.md)."""
