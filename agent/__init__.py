"""The streaming agent: rolling windows per loop, quantification, reports."""
