"""The one number grammar of pmr_ros: params files, the model topic and the command line read numbers alike.

YAML's and ROS 2 parameters' plain decimal forms: an optional sign, digits
with an optional decimal point, an optional exponent (``12``, ``-0.5``,
``.5``, ``7.``, ``1e9``, ``1.0e-3``).  No hexadecimal or octal (``0x10``,
``0o17``), no digit separators (``1_9.4``), no sexagesimal (``1:30``): PyYAML
(YAML 1.1) read those as numbers and Python's ``int``/``float`` read some of
them too, while a node's ROS parameter parser refused them -- and PyYAML read
``1e9`` (no decimal point) as text, which the nodes took as a number.  A
leading zero is decimal (``010`` is ten, not octal eight).  YAML's
infinities (``.inf``, ``-.inf``, ``+.Inf``, ``.INF``) are read as infinite
floats: a limit that is not there (``mpc.output_low``, ``mpc.output_high``);
every other range check refuses them.  ``.nan`` stays what YAML makes of it
and is refused everywhere.
"""

from __future__ import annotations

import re

__all__ = ["grammar_int", "grammar_tag", "is_integer_text", "parse_number"]

INT_TAG, FLOAT_TAG, STR_TAG = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float", "tag:yaml.org,2002:str"

_INTEGER = re.compile(r"[-+]?[0-9]+").fullmatch
_DECIMAL = re.compile(r"[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?").fullmatch
_INFINITY = re.compile(r"[-+]?\.(?:inf|Inf|INF)").fullmatch


def is_integer_text(text: str) -> bool:
    """Whether ``text`` is a whole number in the grammar's integer form (no point, no exponent).

    Examples
    --------
    >>> is_integer_text("010"), is_integer_text("1e9"), is_integer_text("0x10")
    (True, False, False)
    """
    return _INTEGER(text) is not None


def parse_number(text: str) -> int | float | None:
    """The number ``text`` spells in the grammar (an int without point or exponent), else None.

    Examples
    --------
    >>> parse_number("1e9"), parse_number("010"), parse_number("-.5")
    (1000000000.0, 10, -0.5)
    >>> parse_number("0x10"), parse_number("1_9.4"), parse_number("1:30"), parse_number("nan")
    (None, None, None, None)
    >>> parse_number("-.inf"), parse_number(".Inf"), parse_number("inf")
    (-inf, inf, None)
    """
    text = text.strip()
    if _INTEGER(text):
        return int(text)
    if _DECIMAL(text):
        return float(text)
    if _INFINITY(text):
        return float(text.replace(".", "").lower())
    return None


def grammar_tag(value: str, yaml_tag: str) -> str:
    """The YAML tag of a plain scalar under the grammar, given the tag YAML 1.1 resolved it to.

    A number of the grammar is an int or a float; what YAML 1.1 took for a
    number outside the grammar (``0x10``, ``1_9.4``, ``1:30``) is text, so the
    parameter check refuses it as no number; YAML's ``.inf``/``.nan`` stay floats.

    Examples
    --------
    >>> grammar_tag("1e9", STR_TAG) == FLOAT_TAG, grammar_tag("0x10", INT_TAG) == STR_TAG
    (True, True)
    """
    number = parse_number(value)
    if number is not None:
        return INT_TAG if isinstance(number, int) else FLOAT_TAG
    if yaml_tag == INT_TAG or (yaml_tag == FLOAT_TAG and value.strip().lstrip("+-").lower() not in (".inf", ".nan")):
        return STR_TAG
    return yaml_tag


def grammar_int(loader: object, node: object) -> int:
    """Constructor of YAML ints: decimal (``010`` is ten); an explicit ``!!int 0x10`` as YAML reads it."""
    from yaml.constructor import SafeConstructor

    value = parse_number(str(getattr(node, "value", "")))
    if isinstance(value, int):
        return value
    return int(SafeConstructor.construct_yaml_int(loader, node))  # type: ignore[arg-type]
