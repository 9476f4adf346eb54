"""Colours as people write them: ``"#rrggbb"``, ``"#rgb"`` or three numbers in [0, 1]."""

from cadpipe.errors import InputError


def parse_color(color):
    """An RGB triple of floats in [0, 1] from ``"#rrggbb"``, ``"#rgb"`` or three numbers."""
    if isinstance(color, str):
        text = color.strip().lstrip("#")
        if len(text) == 3:
            text = "".join(c * 2 for c in text)
        if len(text) != 6:
            raise InputError(f"expected '#rrggbb', got {color!r}", key="color")
        try:
            return tuple(int(text[i:i + 2], 16) / 255.0 for i in (0, 2, 4))
        except ValueError:
            raise InputError(f"expected '#rrggbb', got {color!r}", key="color") from None
    try:
        rgb = tuple(float(c) for c in color)
    except (TypeError, ValueError):
        raise InputError(f"expected '#rrggbb' or 3 numbers, got {color!r}",
                         key="color") from None
    if len(rgb) != 3 or not all(0.0 <= c <= 1.0 for c in rgb):
        raise InputError(f"expected 3 numbers in [0, 1], got {color!r}", key="color")
    return rgb
