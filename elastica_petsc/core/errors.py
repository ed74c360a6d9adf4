"""The one exception type for user mistakes.

Anything derived from :class:`InputError` is reported by the command line as a
single line ``elastica-petsc: error: ...`` with exit status 2, never as a
traceback.
"""


class InputError(ValueError):
    """Bad input from the user: a config file, a command-line value, a path."""
