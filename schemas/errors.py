"""Errors a user can act on, raised at every layer: the command line prints the message on one line and exits 2."""


class StictionError(Exception):
    """Base of every error whose message tells the user what was wrong and what was expected."""


class InputError(StictionError):
    """Bad input: a file, a row, a field or a flag that is not what was expected."""
