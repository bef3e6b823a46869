"""End-to-end pipelines behind the command line (one module per study type)."""
