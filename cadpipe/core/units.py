"""Length units: the names cadpipe accepts and how many metres each is."""

from types import MappingProxyType

from cadpipe.errors import InputError

#: length units a value can be in, as metres per unit
UNITS = MappingProxyType({"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048})


def meters_per_unit(units):
    """Metres in one ``units`` (a key of :data:`UNITS`); :class:`InputError` otherwise."""
    try:
        return UNITS[units]
    except (KeyError, TypeError):
        raise InputError(f"units: expected one of {', '.join(UNITS)}, got {units!r}") from None
