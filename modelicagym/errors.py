"""Placeholder of the error hierarchy (replaced by the full module when it lands)."""


class ModelicaGymError(Exception):
    """Root of every error modelicagym raises."""


class ConfigError(ModelicaGymError, ValueError):
    """A config value is wrong."""


class ConfigTypeError(ConfigError, TypeError):
    """A config value has the wrong type."""


class ArgumentError(ModelicaGymError, ValueError):
    """An argument of a call is wrong."""


class ArgumentTypeError(ArgumentError, TypeError):
    """An argument of a call has the wrong type."""
