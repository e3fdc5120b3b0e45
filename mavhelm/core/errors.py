"""Errors in files a person wrote (missions, fault scenarios): located like a compiler's."""

from __future__ import annotations


class LocatedError(ValueError):
    """Says ``file:line: reason`` on one line: where it is, and what was expected there."""

    def __init__(self, file: str, line: int, reason: str) -> None:
        super().__init__(f"{file}:{line}: {reason}")
        self.file = file
        self.line = line
        self.reason = reason
