"""How messages write counts and the values they quote from a user's files."""
from __future__ import annotations


def counted(count: int | str, noun: str) -> str:
    """``count`` and ``noun``, plural unless the count is 1: "1 oilpaint stroke", "500 oilpaint strokes"."""
    return f"{count} {noun}" + ("" if str(count) == "1" else "s")


def shown(value) -> str:
    """A value from a file as a message quotes it: on one line, at most 40 characters."""
    text = repr(value)
    return text if len(text) <= 40 else text[:39] + "…"
