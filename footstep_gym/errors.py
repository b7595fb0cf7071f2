"""The package's exceptions: one base class, subclasses of ``ValueError`` for bad input."""


class FootstepGymError(Exception):
    """Base class of every error footstep_gym raises on purpose."""


class ConfigError(FootstepGymError, ValueError):
    """A configuration key is unknown, missing, of the wrong type or out of range."""


class ActionError(FootstepGymError, ValueError):
    """An action has the wrong shape or a non-finite field."""
