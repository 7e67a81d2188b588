"""The exceptions of a run that stopped early (:mod:`harness.run`): :class:`RunWarning` (a partial result
returned) and :class:`RunInterrupted` (Ctrl-C or SIGTERM, with the result so far)."""

from __future__ import annotations


class RunWarning(UserWarning):
    """A run that stopped early and returned a partial result."""


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT) or, under the command line, SIGTERM during a run: ``partial`` is the result up to the
    last finished communication point, marked ``attrs["complete"] = False``, ``attrs["interrupted"] = True``;
    ``status`` is the exit status a shell expects after that signal (130 or 143)."""

    def __init__(self, message: str, partial=None, status: int = 130):
        super().__init__(message)
        self.partial = partial
        self.status = status
