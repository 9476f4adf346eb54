"""Spec templates: ``${name}`` placeholders in a spec's values, filled from parameter sets.

A spec becomes a template by writing ``"${name}"`` where a value goes. A string that is
exactly one placeholder takes the parameter's value with its type (``radius = "${r}"``
becomes ``radius = 0.02``, ``path = "${points}"`` a list); a placeholder inside a longer
string is replaced by the value's text (``name = "duct-${r}"`` becomes ``"duct-0.02"``).
``$${`` writes a literal ``${``. Table keys are never filled. Every placeholder needs a
value and every parameter must be used, so a misspelt name is an error, not a silent
default.

Parameter sets come from a job's ``params`` (one set), ``grid`` (every combination, the
last key varying fastest, as :func:`itertools.product`) or ``rows`` (a CSV file with a
header row, or a list of tables; one set per row); ``params`` are shared by every set of
``grid`` or ``rows``.
"""

import csv
import itertools
import math
import re

from cadpipe import limits
from cadpipe.errors import InputError

#: ``${name}`` (group 1), or ``$${`` (an escaped literal ``${``)
PLACEHOLDER = re.compile(r"\$\$\{|\$\{([A-Za-z_][A-Za-z0-9_]*)\}")
_LOOSE = re.compile(r"\$\{")          # what is left after the well-formed ones are taken out


def placeholders(value):
    """The set of parameter names ``value`` (a spec table, list or scalar) uses."""
    if isinstance(value, dict):
        return set().union(*map(placeholders, value.values()))
    if isinstance(value, list):
        return set().union(*map(placeholders, value))
    if isinstance(value, str):
        return {m.group(1) for m in PLACEHOLDER.finditer(value) if m.group(1)}
    return set()


def _text(value, name, key):
    """A scalar parameter as it reads inside a longer string."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, str)):
        return str(value)
    raise InputError(f"${{{name}}} is inside a longer string, so its value must be a number or "
                     f"a string, got {value!r}", key=key)


def _fill_string(text, values, key):
    whole = PLACEHOLDER.fullmatch(text)
    if whole and whole.group(1):
        return values[whole.group(1)]

    def replace(m):
        return "${" if m.group(1) is None else _text(values[m.group(1)], m.group(1), key)

    if _LOOSE.search(PLACEHOLDER.sub("", text)):
        raise InputError(f"malformed placeholder in {text!r}: write ${{name}} with a name of "
                         "letters, digits and _, or $${ for a literal ${", key=key)
    return PLACEHOLDER.sub(replace, text)


def fill(value, values, key=""):
    """``value`` with every placeholder replaced from ``values`` (a dict by name).

    Parameters
    ----------
    value : dict, list or scalar
        A parsed spec table (or any part of one).
    values : dict
        One parameter set; it must give every name :func:`placeholders` finds.
    key : str
        Where ``value`` sits, for error messages.

    Returns
    -------
    The same structure, filled in; ``value`` itself is not changed.
    """
    if isinstance(value, dict):
        return {k: fill(v, values, f"{key}.{k}" if key else k) for k, v in value.items()}
    if isinstance(value, list):
        return [fill(v, values, f"{key}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, str):
        return _fill_string(value, values, key)
    return value


def check_names(used, values, where):
    """Raise :class:`InputError` unless the template's ``used`` names and a parameter
    set's names are the same; ``where`` names the parameter source (``"grid"``)."""
    missing, unused = sorted(used - set(values)), sorted(set(values) - used)
    if missing:
        given = ", ".join(sorted(values)) or "none"
        raise InputError(f"the spec uses ${{{missing[0]}}} but no value is given for it "
                         f"(parameters: {given})", key=where)
    if unused:
        raise InputError(f"parameter {unused[0]!r} is not used by any ${{{unused[0]}}} in the "
                         "spec; remove it or add the placeholder", key=where)


def _cell(text):
    """A CSV cell as a spec value: true/false, a whole number, a number, or the text."""
    if text in ("true", "false"):
        return text == "true"
    if re.fullmatch(r"[+-]?\d+", text):
        return int(text)
    try:
        number = float(text)
    except ValueError:
        return text
    return number if math.isfinite(number) else text


def csv_rows(file):
    """Parameter sets from a CSV file: a header row of names, then one set per row.

    Returns a list of dicts. Raises :class:`InputError` (``file`` and ``index``, the
    1-based line, set) for an empty file, a blank or repeated name, a short or long row
    or an empty cell.
    """
    try:
        with open(file, encoding="utf-8", newline="") as fh:
            lines = [row for row in csv.reader(fh) if row and not row[0].startswith("#")]
    except UnicodeDecodeError:
        raise InputError("not a text file; expected a CSV of parameter values",
                         file=file) from None
    if len(lines) < 2:
        raise InputError("expected a header row of parameter names and at least one row of "
                         "values", file=file)
    header = [name.strip() for name in lines[0]]
    for name in header:
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name) or header.count(name) > 1:
            raise InputError(f"line 1: {name!r} is not a parameter name (letters, digits and "
                             "_, each once)", file=file, index=1)
    rows = []
    for line, row in enumerate(lines[1:], start=2):
        if len(row) != len(header):
            raise InputError(f"line {line}: {len(row)} values for {len(header)} columns "
                             f"({', '.join(header)})", file=file, index=line)
        cells = [c.strip() for c in row]
        if "" in cells:
            raise InputError(f"line {line}: column {header[cells.index('')]!r} is empty", file=file,
                             index=line)
        rows.append(dict(zip(header, map(_cell, cells))))
    return rows


def parameter_sets(params=None, grid=None, rows=None):
    """The parameter sets of one job entry, in order.

    Parameters
    ----------
    params : dict, optional
        Values shared by every set (the only set when neither ``grid`` nor ``rows``).
    grid : dict of lists, optional
        Every combination of the listed values, the last key varying fastest.
    rows : list of dicts, optional
        One set per row (from :func:`csv_rows` or a list of tables).

    Returns
    -------
    list of dict
        At least one set (``[{}]`` for a job without parameters).
    """
    params = dict(params or {})
    if grid is not None and rows is not None:
        raise InputError("give grid or rows, not both (put shared values in params)",
                         key="rows")
    if grid is not None:
        if not grid:
            raise InputError("expected at least one parameter", key="grid")
        for name, choices in grid.items():
            if not isinstance(choices, list) or not choices:
                raise InputError(f"expected a non-empty list of values, got {choices!r}",
                                 key=f"grid.{name}")
        count = math.prod(len(choices) for choices in grid.values())
        sizes = " x ".join(str(len(choices)) for choices in grid.values())
        limits.check("max_jobs", count, f"a grid of {sizes} combinations", key="grid")
        sets = [dict(zip(grid, combo)) for combo in itertools.product(*grid.values())]
        where = "grid"
    elif rows is not None:
        for i, row in enumerate(rows):
            if not isinstance(row, dict):
                raise InputError(f"expected a table of parameter values, got {row!r}",
                                 key=f"rows[{i}]")
        limits.check("max_jobs", len(rows), f"{len(rows):,} rows", key="rows")
        sets, where = [dict(row) for row in rows], "rows"
    else:
        return [params]
    if not sets:
        raise InputError("expected at least one row", key=where)
    for i, values in enumerate(sets):
        shared = sorted(set(values) & set(params))
        if shared:
            raise InputError(f"{shared[0]!r} is given in both params and {where}",
                             key=f"{where}[{i}]")
    return [{**params, **values} for values in sets]
