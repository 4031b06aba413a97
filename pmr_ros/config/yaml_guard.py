"""Checks on a composed YAML document before it is built: no duplicate key, bounded alias expansion.

YAML lets a mapping repeat a key; PyYAML keeps the last one without a word,
so a second ``gain:`` line silently replaced the first and a second
``mismatch:`` block cancelled the scenario.  YAML also lets an alias repeat
an anchored node: nine lines of nine aliases each (a 1 KB "billion laughs")
stand for 9**9 nodes.  The composer shares an aliased node rather than
copying it, so composing is cheap; what explodes is every later walk over
the built document (validation, comparison, dumping), 36 s to 5.8 GB.

Both are found on the composed node graph, before anything is built, in one
pass over its *distinct* nodes: the expanded size of each node is counted
(one plus its children's, each distinct node once), so a bomb is measured,
never expanded.  No ROS imports.
"""

from __future__ import annotations

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

__all__ = ["ALIAS_EXPANSION_LIMIT", "DocumentError", "check_document", "check_duplicate_keys", "expanded_size"]

ALIAS_EXPANSION_LIMIT = 100_000
"""Nodes that aliases may add to a document (over its distinct nodes); a document past it is refused."""

MERGE_TAG = "tag:yaml.org,2002:merge"


class DocumentError(yaml.YAMLError):
    """A document that parses but is refused; ``field`` is the dotted key path, ``reason`` says why.

    Parameters
    ----------
    field : str
        Dotted path of the offending key (``system.gain``), ``<file>`` for the whole document.
    reason : str
        What is wrong, with the line numbers (1-based) concerned.
    """

    def __init__(self, field: str, reason: str, lines: tuple[int, ...] = ()) -> None:
        self.field, self.reason, self.lines = field, reason, lines
        super().__init__(f"{field}: {reason}")

    def located(self, source: str) -> str:
        """The reason with each line as ``source:line`` (a file name the user can click)."""
        if len(self.lines) != 2:
            return self.reason
        first, second = self.lines
        return self.reason.replace(f"lines {first} and {second}", f"{source}:{first} and {source}:{second}")


def _children(node: Node) -> list[Node]:
    if isinstance(node, SequenceNode):
        return list(node.value)
    if isinstance(node, MappingNode):
        return [part for pair in node.value for part in pair]
    return []


def expanded_size(root: Node) -> tuple[int, int]:
    """The node count of ``root`` with every alias expanded, and its count of distinct nodes.

    Each distinct node is visited once (sizes are summed, never expanded), so
    the time and memory are linear in the composed document.

    Raises
    ------
    DocumentError
        An alias refers to a node that contains it (an infinite expansion).
    """
    sizes: dict[int, int] = {}
    on_path: set[int] = set()
    stack: list[tuple[Node, bool]] = [(root, False)]
    while stack:
        node, finished = stack.pop()
        key = id(node)
        if finished:
            on_path.discard(key)
            sizes[key] = 1 + sum(sizes[id(child)] for child in _children(node))
        elif key in on_path:
            raise DocumentError("<file>", f"an alias on line {node.start_mark.line + 1} refers to a node containing it")
        elif key not in sizes:
            on_path.add(key)
            stack.append((node, True))
            stack.extend((child, False) for child in _children(node) if id(child) not in sizes)
    return sizes[id(root)], len(sizes)


def _key_name(node: Node) -> str | None:
    """A scalar key's text (None for a merge key ``<<`` or a non-scalar key, which are not compared)."""
    if isinstance(node, ScalarNode) and node.tag != MERGE_TAG:
        return str(node.value)
    return None


def _check_mapping(node: MappingNode, path: str) -> None:
    seen: dict[str, int] = {}
    for key, _ in node.value:
        name = _key_name(key)
        if name is None:
            continue
        line = key.start_mark.line + 1
        if name in seen:
            field = f"{path}.{name}" if path else name
            raise DocumentError(
                field,
                f"duplicate key on lines {seen[name]} and {line}"
                " (YAML would keep the second silently); keep one of them",
                (seen[name], line),
            )
        seen[name] = line


def check_duplicate_keys(root: Node) -> None:
    """Refuse a mapping that repeats a key, naming the key's path and both lines.

    Raises
    ------
    DocumentError
        With ``field`` the dotted path of the repeated key.
    """
    visited: set[int] = set()
    stack: list[tuple[Node, str]] = [(root, "")]
    while stack:
        node, path = stack.pop()
        if id(node) in visited:
            continue
        visited.add(id(node))
        if isinstance(node, MappingNode):
            _check_mapping(node, path)
            pairs = [(value, f"{path}.{key.value}" if path else str(key.value)) for key, value in node.value]
            stack.extend(reversed(pairs))  # document order: the first duplicate is the one reported
        elif isinstance(node, SequenceNode):
            stack.extend(reversed([(child, f"{path}[{i}]") for i, child in enumerate(node.value)]))


def check_document(root: Node, *, limit: int = ALIAS_EXPANSION_LIMIT) -> None:
    """Refuse a composed document with a duplicate key or whose aliases expand past ``limit`` nodes.

    Parameters
    ----------
    root : yaml.Node
        The composed document (``loader.get_single_node()``).
    limit : int, optional
        Nodes the aliases may add over the document's distinct nodes.

    Raises
    ------
    DocumentError
        One line: the key path and both lines, or the expanded and the written size.

    Examples
    --------
    >>> check_document(yaml.compose("{a: 1, b: 2}"))
    >>> check_document(yaml.compose("{a: 1, a: 2}"))
    Traceback (most recent call last):
    ...
    pmr_ros.config.yaml_guard.DocumentError: a: duplicate key on lines 1 and 1 (YAML would keep ...
    """
    expanded, distinct = expanded_size(root)
    if expanded - distinct > limit:
        raise DocumentError(
            "<file>",
            f"aliases expand {distinct:,} written nodes to {expanded:,} (more than {limit:,} added);"
            " refused as an alias bomb: write the values out",
        )
    check_duplicate_keys(root)
