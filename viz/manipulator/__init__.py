"""The arm's rerun views and report image."""
