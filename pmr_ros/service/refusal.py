"""Why a service flow stops: :class:`ServiceError`, one line for the user and the exit code it deserves."""

from __future__ import annotations

__all__ = ["EXIT_INSUFFICIENT", "ServiceError"]

EXIT_INSUFFICIENT = 3
"""Exit code of a flow that ran but had too little data (or no verdict) for what was asked."""


class ServiceError(Exception):
    """A flow cannot go on (bad input, too little data); the message is one line naming the cause.

    Attributes
    ----------
    code : int
        The exit code a command ends with (2 bad input, 3 too little data).
    """

    def __init__(self, message: str, code: int = 2) -> None:
        super().__init__(message)
        self.code = code
