"""End-to-end workflows of the papers (the one place that joins simulation, identification,
analysis and control)."""
