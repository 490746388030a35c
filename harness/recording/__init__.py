"""harness.recording (see ARCHITECTURE.md)."""
