"""The errors a run ends with in one line: a user's input nsp cannot work with, or a run that could
not go on; their messages are the single line the user sees."""


class BadInput(ValueError):
    """A value nsp cannot work with; the message names it and what would be valid."""


class RunFailed(RuntimeError):
    """A run that could not go on (training diverged); the message says where it stopped and what it kept."""
