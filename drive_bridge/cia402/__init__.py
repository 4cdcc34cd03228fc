"""CiA 402 (drives and motion control): vocabulary, state machine, axis."""
