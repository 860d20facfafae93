"""Integrator names -> classes.  Built-in methods register themselves; users add their own:

    @register
    class MyMethod(OdeSolver):
        name = "my-method"
        ...
"""

from __future__ import annotations

from ..errors import UsageError
from .base import OdeSolver

_METHODS: dict[str, type[OdeSolver]] = {}


def register(cls: type[OdeSolver]) -> type[OdeSolver]:
    """Register an OdeSolver subclass under ``cls.name`` (case-insensitive); usable as a decorator.
    A later registration of the same name replaces the earlier one."""
    if not (isinstance(cls, type) and issubclass(cls, OdeSolver)):
        raise UsageError(f"{cls!r} is not an OdeSolver subclass")
    if not cls.name:
        raise UsageError(f"{cls.__name__} has no name to register it under")
    _METHODS[cls.name.lower()] = cls
    return cls


def get_integrator(name: str | type[OdeSolver]) -> type[OdeSolver]:
    """The class registered as ``name``; an OdeSolver subclass is returned as it is."""
    if isinstance(name, type) and issubclass(name, OdeSolver):
        return name
    try:
        return _METHODS[str(name).lower()]
    except KeyError:
        raise UsageError(f"unknown integrator '{name}' (available: {', '.join(available())})") from None


def available() -> list[str]:
    """Registered integrator names."""
    return [cls.name for cls in _METHODS.values()]
