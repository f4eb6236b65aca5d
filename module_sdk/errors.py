"""The exception tree of the module SDK.

Tree::

    SdkError                        the root: every error module_sdk raises
    └── BuildError (RuntimeError)   a module cannot be built: a missing tool or source, a tool
                                    that failed
"""

from __future__ import annotations


class SdkError(Exception):
    """Base class of every error the module SDK raises."""


class BuildError(SdkError, RuntimeError):
    """A module could not be built: a missing tool, a missing source, or a tool that failed."""
