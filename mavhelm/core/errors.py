"""Errors in files a person wrote (missions, fault scenarios): located like a compiler's."""

from __future__ import annotations


class LocatedError(ValueError):
    """Says ``file:line: reason`` on one line: where it is, and what was expected there."""

    def __init__(self, file: str, line: int, reason: str) -> None:
        super().__init__(f"{file}:{line}: {reason}")
        self.file = file
        self.line = line
        self.reason = reason


class SettingError(Exception):
    """A setting accepted at load that fails when used (a log folder made read-only, a disk
    full, a file system that refuses the name): says which setting and why, in one line, so
    the cause is not mistaken for another (the autopilot link's)."""

    def __init__(self, setting: str, what: str, exc: BaseException) -> None:
        why = getattr(exc, "strerror", None) or str(exc)
        super().__init__(f"cannot open {what} ({setting}): {why}")
        self.setting = setting
