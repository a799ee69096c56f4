"""The `interbot` command: demo, headless scenarios and benchmarks (a thin composition root)."""
