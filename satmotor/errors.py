"""The one exception type the physics package raises for bad parameters."""


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
