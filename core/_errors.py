"""Errors with structured fields, for callers that must not parse message text (a leaf module).

:class:`ArgumentError` is the ``ValueError`` of a refused argument: its
message is the project's ``"name: expected ..., got ..."`` and its
``argument`` field holds ``name``, and its ``limit`` field the accepted
value nearest the refused one when core found it on the way, so an
application can say what to change without reading the text (or asking
core again)::

    try:
        cam = CamFollower(profile, follower="roller", roller_radius=r)
    except ArgumentError as exc:
        if exc.argument == "roller_radius":
            ...  # exc.limit: the largest roller (m) that does not undercut the cam
"""

from __future__ import annotations

__all__ = ["ArgumentError", "RigidModeWarning"]


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
    limit : float or None, keyword-only
        The bound of the accepted values of ``argument`` that the refused
        value crossed, in its unit, when the check computed it (the largest
        roller radius that does not undercut a cam, the base radius a flat
        face needs); None otherwise. The message states it too.
    """

    def __init__(self, argument: str, message: str, *, limit: float | None = None):
        super().__init__(message)
        self.argument = argument
        self.limit = limit

    def __reduce__(self):  # (pickles across the app's process pool with its fields)
        return (_rebuild, (type(self), self.argument, str(self), self.limit))


def _rebuild(cls: type[ArgumentError], argument: str, message: str, limit: float | None) -> ArgumentError:
    return cls(argument, message, limit=limit)


class RigidModeWarning(UserWarning):
    """:meth:`rigidlab.core.modal.Modes.animate` of a rigid-body (zero-eigenvalue) mode: the mechanism moves
    along it as a rigid body, it does not oscillate (:attr:`~rigidlab.core.modal.Modes.flexible` leaves such
    modes out). Here, in the leaf module, so an application can filter it without importing the modal code."""
