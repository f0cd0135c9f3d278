"""Exceptions that reach the user as one plain line (the CLI prints them without a traceback)."""

from __future__ import annotations


class MicropitError(Exception):
    """Base class of every error the user can fix (bad input, missing environment).

    ``collective``: True when every rank of the job raises the same error at the same point
    (the verdict was agreed by a collective call, or every rank read the same input), so that
    rank 0 can report it once and every rank can leave normally. Any other error is
    rank-local: the CLI prints it on the rank that had it and aborts the whole job
    (``MPI_Abort``), since the other ranks may be waiting for this one in a collective call.
    """

    collective = False


def collective(error: MicropitError) -> MicropitError:
    """Mark ``error`` as raised on every rank alike (see :class:`MicropitError`)."""
    error.collective = True
    return error


class SceneError(MicropitError):
    """A scene file that cannot be used, with the file, the key, the value and what is allowed.
    Collective: every rank reads the same scene file and checks it the same way."""

    collective = True

    def __init__(self, source: str, problem: str, key: str | None = None, value: object = None,
                 allowed: str | None = None):
        self.source, self.key, self.value, self.problem, self.allowed = (
            source, key, value, problem, allowed)
        where = f"{source}: " if source else ""
        if key is None:
            text = f"{where}{problem}"
        else:
            text = f"{where}{key} = {format_value(value)}: {problem}"
        if allowed:
            text += f" (allowed: {allowed})"
        super().__init__(text)


def format_value(value: object) -> str:
    """A value as it would be written in TOML, for error messages."""
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    if hasattr(value, "isoformat"):  # TOML dates and times
        return value.isoformat()
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {format_value(v)}" for k, v in value.items()) + "}"
    return repr(value)
