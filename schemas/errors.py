"""Errors a user can act on, raised at every layer: the command line prints the message on one line and exits 2."""


class StictionError(Exception):
    """Base of every error whose message tells the user what was wrong and what was expected."""


class InputError(StictionError):
    """Bad input: a file, a row, a field or a flag that is not what was expected."""


def as_stiction_error(e: Exception) -> StictionError:
    """``e`` as the one line a user reads: itself where it is ours to say, else a fault of ours met in this one
    input (named by its class and message), so that it costs that input alone and the others go on."""
    if isinstance(e, StictionError):
        return e
    return StictionError(f"internal error ({e.__class__.__name__}: {e}); please report it with this input")

