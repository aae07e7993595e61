"""A test-only robot: an Ackermann car through the shared bicycle kinematics and the shared
discovery engine (:mod:`ackermann.car`)."""
