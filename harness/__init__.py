"""Co-simulation master (FMPy) and controllers (rule-based, MPC)."""
