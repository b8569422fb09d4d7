"""The exceptions haptex raises.

Every error haptex raises is a :class:`HaptexError`, and also the built-in
class a Python user would catch for it: bad input (a value out of its
range, a malformed file, options that do not go together) is a
``ValueError``, a file that cannot be read or written an ``OSError``. The
message is the one the ``haptex`` command line prints after ``error:``.
"""

__all__ = [
    "HaptexError",
    "InvalidInputError",
    "HaptexOSError",
    "ComputationError",
    "CancelledError",
    "ExtrapolationWarning",
]


class HaptexError(Exception):
    """Base class of every haptex error."""


class InvalidInputError(HaptexError, ValueError):
    """A value, a file's content or a combination of options haptex refuses.

    The message names the argument, file, line or field, as the command
    line's does."""


class HaptexOSError(HaptexError, OSError):
    """A file that could not be opened, read or written."""


class ComputationError(HaptexError, RuntimeError):
    """A computation that did not reach its result (an FE run that did not
    converge, for instance); the message says where it stopped."""


class CancelledError(HaptexError):
    """Long work stopped because its progress callback returned False."""


class ExtrapolationWarning(UserWarning):
    """A prediction far from every case of the model matrix or database
    (paper footnote 6: extreme extrapolation may give erroneous values);
    the message says which inputs and the nearest case."""
