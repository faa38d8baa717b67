"""The one error a user's input raises: its message is the single line they see."""


class BadInput(ValueError):
    """A value nsp cannot work with; the message names it and what would be valid."""
