"""logcal visualisation: rerun recordings, blueprints and static report plots."""
