"""Pydantic message models: the only contract between processes."""
