"""Errors with structured fields, for callers that must not parse message text (a leaf module).

:class:`ArgumentError` is the ``ValueError`` of a refused argument: its
message is the project's ``"name: expected ..., got ..."`` and its
``argument`` field holds ``name``, so an application can say what to change
without reading the text::

    try:
        cam = CamFollower(profile, follower="roller", roller_radius=r)
    except ArgumentError as exc:
        if exc.argument == "roller_radius":
            ...
"""

from __future__ import annotations

__all__ = ["ArgumentError"]


class ArgumentError(ValueError):
    """A refused argument (a ``ValueError``): ``argument`` names it.

    Parameters
    ----------
    argument : str
        The argument's name as the message starts with it (``"roller_radius"``,
        ``"state.q"``, or several comma-separated names, ``"rise, dwell, fall"``,
        when only their combination is refused).
    message : str
        ``"<argument>: expected ..., got ..."``.
    """

    def __init__(self, argument: str, message: str):
        super().__init__(message)
        self.argument = argument

    def __reduce__(self):  # (pickles across the app's process pool with its field)
        return (type(self), (self.argument, str(self)))
