"""Error types users see. Every message names the offending field and what is allowed."""

__all__ = [
    "BudgetError",
    "InputError",
    "JaxflexError",
    "JaxflexWarning",
    "ModelError",
    "ModelFileError",
    "OutputError",
]


class JaxflexError(Exception):
    """Base class of every error jaxflex raises on purpose."""


class InputError(JaxflexError, ValueError):
    """A value passed by the user is out of range or has the wrong shape."""


class ModelError(InputError):
    """A ModalModel field is inconsistent (shape, finiteness, range)."""


class ModelFileError(JaxflexError, OSError):
    """A model file cannot be read: missing, truncated, corrupt or of an unknown schema."""


class OutputError(JaxflexError, OSError):
    """An output cannot be written where asked: the target is not a regular file, its
    directory does not exist, or the file system refused the write."""


class JaxflexWarning(UserWarning):
    """Input that is allowed but probably not meant (a threshold in mm given as m, a robust
    check grid of one point): the work goes on, the message says what looks wrong and why.
    The command line prints it as ``jaxflex COMMAND: warning: ...``."""


class BudgetError(InputError):
    """A request needs more work or memory than its budget allows. The message says what
    the request needs, the budget, and the option that limits it."""
