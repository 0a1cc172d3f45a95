"""Is a loop oscillating, and is it the valve: tests on one window of OP and PV (numpy only)."""
