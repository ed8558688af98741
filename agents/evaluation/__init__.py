"""Evaluation: fixed suites, the episode runner, the benchmark, its report and statistics."""
