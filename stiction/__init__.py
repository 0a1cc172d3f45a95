"""The ``stiction`` command."""
