"""Job execution: per-object extraction, the central commit (dedup + dataset), runners and status."""
