"""The parameter declaration of ``config/parameters.yaml``: defaults, types, ranges, meanings.

Every other place that needs a default, a range or a description (the config
reader, the ROS 2 parameter descriptors, ``pmr-ros params``) takes it from
here, so each is written once.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from functools import cache
from typing import Any

from ..resources import share_dir
from .errors import ConfigError
from .files import load_yaml
from .value_checks import Shape, ValueChecks, element_label

__all__ = [
    "KINDS",
    "SCHEMA_FILE",
    "Block",
    "ConfigError",
    "Parameter",
    "Shape",
    "blocks",
    "closest_name",
    "default_tree",
    "element_label",
    "parameter",
    "parameters",
]

SCHEMA_FILE = "parameters.yaml"
"""The declaration file in the package's ``config/`` folder."""

KINDS = (
    "int",
    "float",
    "bool",
    "string",
    "names",
    "channels",
    "matrix",
    "types",
    "columns",
    "values",
    "strings",
    "stretches",
    "labels",
)
"""Parameter types of the declaration (see its header comment)."""

_REQUIRED = object()


@dataclass(frozen=True)
class Parameter(ValueChecks):
    """One declared parameter.

    Attributes
    ----------
    name : str
        Dotted name, ``block.key``.
    kind : str
        One of :data:`KINDS`.
    default : object
        The default; :attr:`required` when there is none.
    minimum, maximum : float or None
        Bounds, inclusive unless :attr:`min_exclusive` / :attr:`max_exclusive`.
    choices : tuple of str
        Allowed strings (empty: any).
    per : str
        ``outputs``, ``inputs`` or ``disturbances`` for ``channels``, ``columns`` and ``types``: one
        per channel; ``disturbance_elements`` for a ``matrix`` or ``types`` of n_outputs x
        n_disturbances (the DV model).
    scalar : bool
        A ``matrix`` may be one number for every element.
    integer : bool
        The numbers of a ``matrix`` must be whole.
    infinite : bool
        ``.inf`` and ``-.inf`` are allowed (a limit that is not there); NaN never is.
    unit, doc : str
    nodes : tuple of str
        The executables that declare it.
    live : tuple of str
        The executables that accept a change of it at runtime (the block's
        ``live``); for the others it is read-only once the node started.
    blank : bool
        A ``columns`` list may leave a channel without a column (``""`` or ``~``);
        with ``scalar`` it may be one name for every channel, and ``per:
        disturbances`` counts the DVs (see :mod:`pmr_ros.config.column_lists`).
    """

    name: str
    kind: str
    default: Any = _REQUIRED
    minimum: float | None = None
    maximum: float | None = None
    min_exclusive: bool = False
    max_exclusive: bool = False
    choices: tuple[str, ...] = ()
    per: str = ""
    scalar: bool = False
    integer: bool = False
    infinite: bool = False
    unit: str = ""
    doc: str = ""
    nodes: tuple[str, ...] = ()
    live: tuple[str, ...] = ()
    blank: bool = False

    @property
    def required(self) -> bool:
        """Whether a file must give it (no default)."""
        return self.default is _REQUIRED

    @property
    def block(self) -> str:
        """The block (``mpc`` of ``mpc.prediction_horizon``)."""
        return self.name.split(".", 1)[0]

    def describe(self) -> str:
        """One line for a ROS descriptor or a listing: meaning, unit, range."""
        text = self.doc
        if self.unit:
            text += f" [{self.unit}]"
        bounds = self.range_text()
        return f"{text}; {bounds}" if bounds else text

    # -- checking ------------------------------------------------------------
    def check(self, value: Any, *, source: str, shape: Shape | None = None) -> Any:
        """The value as the core wants it, or :class:`ConfigError` naming this parameter.

        ``int``/``float`` give Python numbers, ``string`` a str, ``names`` a
        tuple, ``channels`` an ndarray of shape (channels,), ``matrix`` an
        ndarray (n_outputs, n_inputs).  ``shape`` is needed for the last two.
        """
        checker = getattr(self, f"_check_{self.kind}")
        return checker(value, source, shape)


@dataclass(frozen=True)
class Block:
    """A block of parameters (``mpc``), with the nodes that declare it."""

    name: str
    doc: str
    nodes: tuple[str, ...]
    parameters: tuple[Parameter, ...]
    optional: bool = False


def _parameter(block: str, key: str, entry: dict, nodes: tuple[str, ...], live: tuple[str, ...] = ()) -> Parameter:
    kind = entry.get("type")
    if kind not in KINDS:
        raise ValueError(f"{SCHEMA_FILE}: {block}.{key}: type {kind!r} is not one of {', '.join(KINDS)}")
    return Parameter(
        name=f"{block}.{key}",
        kind=kind,
        default=entry.get("default", _REQUIRED),
        minimum=entry.get("min"),
        maximum=entry.get("max"),
        min_exclusive=bool(entry.get("min_exclusive", False)),
        max_exclusive=bool(entry.get("max_exclusive", False)),
        choices=tuple(entry.get("choices", ())),
        per=str(entry.get("per", "")),
        scalar=bool(entry.get("scalar", False)),
        integer=bool(entry.get("integer", False)),
        infinite=bool(entry.get("infinite", False)),
        unit=str(entry.get("unit", "")),
        doc=str(entry.get("doc", "")),
        nodes=tuple(entry.get("nodes", nodes)),
        live=live,
        blank=bool(entry.get("blank", False)),
    )


@cache
def blocks() -> dict[str, Block]:
    """Every block of the declaration, by name, in file order."""
    path = share_dir("config", SCHEMA_FILE) / SCHEMA_FILE
    doc = load_yaml(path)
    out = {}
    for name, entry in doc.items():
        nodes, live = tuple(entry.get("nodes", ())), tuple(entry.get("live", ()))
        params = tuple(_parameter(name, key, spec, nodes, live) for key, spec in entry["parameters"].items())
        out[name] = Block(name, str(entry.get("doc", "")), nodes, params, bool(entry.get("optional", False)))
    return out


@cache
def parameters() -> dict[str, Parameter]:
    """Every declared parameter by dotted name."""
    return {p.name: p for block in blocks().values() for p in block.parameters}


def parameter(name: str) -> Parameter:
    """The declaration of ``name``; KeyError if there is none."""
    return parameters()[name]


def closest_name(name: str, known: list[str] | None = None) -> str | None:
    """The known parameter or block name nearest to a misspelt ``name``, if any is close.

    Examples
    --------
    >>> closest_name("mpc.predicton_horizon")
    'mpc.prediction_horizon'
    """
    candidates = known if known is not None else [*parameters(), *blocks()]
    match = difflib.get_close_matches(name, candidates, n=1, cutoff=0.6)
    return match[0] if match else None


def default_tree(*, blocks_wanted: tuple[str, ...] | None = None) -> dict[str, dict[str, Any]]:
    """The nested tree of every default (required parameters and optional blocks left out)."""
    tree: dict[str, dict[str, Any]] = {}
    for name, block in blocks().items():
        if block.optional or (blocks_wanted is not None and name not in blocks_wanted):
            continue
        values = {p.name.split(".", 1)[1]: p.default for p in block.parameters if not p.required}
        if values:
            tree[name] = values
    return tree
