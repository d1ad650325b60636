"""Control: pure per-axis laws, motion profiles, wrap/flip path choice, fault detection."""
