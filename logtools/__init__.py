"""logcal ingest, alignment, segmentation, CLI and reports: reads logs and orchestrates."""
