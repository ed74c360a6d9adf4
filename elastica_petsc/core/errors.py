"""The package's one exception hierarchy.

* :class:`ElasticaError` is the base of every exception the package raises on
  purpose (``except ep.ElasticaError`` catches them all);
* :class:`InputError` (also a ``ValueError``): bad input from the user: the
  command line reports it as a single line ``elastica-petsc: error: ...`` with
  exit status 2, never as a traceback;
* :class:`SolverError` (also a ``RuntimeError``): a numerical method that
  could not run at all (a singular factorisation, an eigen solve without
  convergence, a curve that cannot be followed).

A solve that merely does not converge is not an exception: it is a result
whose ``converged`` is False and whose ``reason``/``message`` say why.

>>> from elastica_petsc.core.model import Arm
>>> try:
...     Arm.from_toml("no_such_arm.toml")
... except ElasticaError as err:
...     print(type(err).__name__, isinstance(err, InputError))
ConfigError True
"""


class ElasticaError(Exception):
    """Base of every exception raised on purpose by elastica_petsc."""


class InputError(ElasticaError, ValueError):
    """Bad input from the user: a config file, a command-line value, a path."""


class SolverError(ElasticaError, RuntimeError):
    """A numerical method that could not be carried out (not merely "not converged")."""


class InputDeprecation(FutureWarning):
    """Input that still works but is deprecated; the message names what to write
    instead (the command line prints it as ``elastica-petsc: warning: ...``)."""
