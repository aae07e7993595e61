"""The differential drive's rerun views and report image."""
