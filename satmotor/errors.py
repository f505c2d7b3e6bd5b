"""The one exception type the physics package raises for bad parameters, and its number check."""

import math


class ParameterError(ValueError):
    """A parameter has a value the model cannot use.

    Attributes
    ----------
    field : str
        Name of the offending field (dotted path for nested values).
    value : object
        The rejected value.
    reason : str
        Why it was rejected.
    source : str or None
        The file the value came from, when there is one.
    """

    def __init__(self, field, value, reason, source=None):
        self.field = field
        self.value = value
        self.reason = reason
        self.source = source
        where = f"{source}: " if source else ""
        super().__init__(f"{where}{field} = {value!r}: {reason}")


def require_number(field, value, lower=None, inclusive=False, upper=None):
    """``float(value)`` when it is a finite real number (bool is not) above ``lower``
    (``>= lower`` with ``inclusive``) and at most ``upper``; otherwise a :class:`ParameterError`
    naming the field and the value."""
    ok = not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)
    if ok and lower is not None:
        ok = value >= lower if inclusive else value > lower
    if ok and upper is not None:
        ok = value <= upper
    if not ok:
        bound = "" if lower is None else f" {'>=' if inclusive else '>'} {lower}"
        if upper is not None:
            bound += f"{' and' if bound else ''} <= {upper}"
        raise ParameterError(field, value, f"must be a finite number{bound}")
    return float(value)


def require_integer(field, value, lower=None):
    """``value`` when it is an int (bool is not) ``>= lower``; otherwise a :class:`ParameterError`
    naming the field and the value."""
    if isinstance(value, bool) or not isinstance(value, int) or (lower is not None and value < lower):
        raise ParameterError(field, value, "must be an integer" + ("" if lower is None else f" >= {lower}"))
    return value


def require_choice(field, value, choices):
    """``value`` when it is one of ``choices`` (a String parameter's closed set of values, as
    ``satmotor.interface`` lists them in ``Variable.choices``); otherwise a :class:`ParameterError`
    naming the field, the value and the choices (the native core's generated ``sm_choice_parse``
    writes the same text)."""
    if not isinstance(value, str) or value not in choices:
        raise ParameterError(field, value, f"must be one of {', '.join(choices)}")
    return value
