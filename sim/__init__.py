"""The simulated stiction loop: valve, process, disturbances, extensions, batch simulator."""
