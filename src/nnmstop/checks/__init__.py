"""Independent checks in the time domain."""
