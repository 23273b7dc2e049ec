"""The package's own exception types.

Every failure that a user can cause (a bad file, an impossible parameter) is raised as a
:class:`DarcyanError` whose message names the input and the problem, so the command line can
print it as one line and exit with status 2.
"""

from __future__ import annotations


class DarcyanError(Exception):
    """Base class of every error darcyan raises on purpose."""


class MeshError(DarcyanError):
    """A mesh file or array that cannot be used: message is ``"{source}: {problem}"``."""

    def __init__(self, source: object, problem: str):
        self.source = str(source)
        self.problem = problem
        super().__init__(f"{self.source}: {problem}")

    def __reduce__(self):  # so that an error raised in a worker process arrives whole
        return type(self), (self.source, self.problem)


class ConfigError(DarcyanError):
    """A parameter value outside its documented range."""


class DependencyError(DarcyanError):
    """An optional dependency is needed for the requested feature but is not installed."""


def require(module: str, extra: str):
    """Import an optional dependency lazily, or raise a :class:`DependencyError` naming the extra."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise DependencyError(
            f"{module} is needed for this feature: pip install 'darcyan[{extra}]'"
        ) from exc
