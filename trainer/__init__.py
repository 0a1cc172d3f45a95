"""Offline model training (torch); never imported by the agent."""
