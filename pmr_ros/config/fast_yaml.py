"""YAML loading that stays fast on large params files: matrices of many numbers.

PyYAML's C loader parses in C but resolves and builds every scalar in Python;
a params file of a large system (a 540 x 540 model is 7 MB of numbers) then
spends seconds per megabyte on the numbers alone.  Two things are done here,
each giving what ``yaml.load(text, Loader=CSafeLoader)`` gives but for the number grammar:

* numbers follow pmr_ros's one grammar (:mod:`.numbers`), not YAML 1.1's:
  ``1e9`` is a number, ``0x10``, ``1_000`` and ``1:30`` are text, ``010`` is ten;
* plain scalars that are simple decimal numbers (``-12``, ``3.5``,
  ``1.0e-3``) are resolved by two compiled patterns before PyYAML's resolver
  list, and the items of a sequence built by ``int``/``float`` directly;
* in a large text, every one-line flow sequence of such numbers
  (``gain: [2.0, -1.6, 1.4]``) is cut out before parsing and replaced by a
  placeholder plain scalar, which is built as the list of its numbers.  A
  plain scalar stands wherever a flow sequence may, so the document is the
  same -- provided every placeholder was built as a whole node.  When one
  was not (it sat in a quoted string, a comment, a block scalar, or next to
  text that made it part of a longer scalar) or the cut text does not parse,
  the original text is parsed as it is, and PyYAML's answer (or error) stands.

One difference from PyYAML, on purpose: a document with a duplicate key or an
alias bomb is refused (:mod:`.yaml_guard`) before it is built.

``test/test_config_files.py`` compares both loaders on documents built to trip the shortcut.
"""

from __future__ import annotations

import re
import secrets
from typing import Any

import yaml
from yaml.nodes import ScalarNode, SequenceNode

from .numbers import grammar_int, grammar_tag
from .yaml_guard import DocumentError, check_document

__all__ = ["LARGE_TEXT", "load"]

_BASE = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
INT_TAG, FLOAT_TAG, LIST_TAG = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float", "!pmr_ros/number_list"

# Subsets of YAML 1.1's int and float patterns on which int() and float() give PyYAML's values:
# no leading zeros (octal), no underscores, no sexagesimal, no .inf/.nan, no exponent without a dot or sign.
_INT = re.compile(r"[-+]?(?:0|[1-9][0-9]*)").fullmatch
_FLOAT = re.compile(r"[-+]?[0-9]+\.[0-9]*(?:[eE][-+][0-9]+)?").fullmatch
_NUMBER = r"[-+]?(?:[0-9]+\.[0-9]*(?:[eE][-+][0-9]+)?|0|[1-9][0-9]*)"
_LIST = re.compile(r"\[[ \t]*(" + _NUMBER + r"(?:[ \t]*,[ \t]*" + _NUMBER + r")*)[ \t]*,?[ \t]*\]")
_SPLIT = re.compile(r"[ \t]*,[ \t]*")

LARGE_TEXT = 256 * 1024
"""Texts from this many characters on have their number lists cut out before parsing."""


class _Loader(_BASE):  # type: ignore[misc, valid-type]  # PyYAML's loaders are untyped
    """The C safe loader with simple numbers resolved and built without PyYAML's per-scalar machinery."""

    mark = ""
    lists: list[str] = []
    built = 0

    def resolve(self, kind: Any, value: Any, implicit: Any) -> Any:
        if kind is ScalarNode and implicit[0]:
            if _FLOAT(value):
                return FLOAT_TAG
            if _INT(value):
                return INT_TAG
            if self.mark and value.startswith(self.mark) and value[len(self.mark) + 1 :].isdigit():
                return LIST_TAG
            return grammar_tag(value, super().resolve(kind, value, implicit))
        return super().resolve(kind, value, implicit)

    def get_single_data(self) -> Any:
        """The document, built only once :func:`.yaml_guard.check_document` passed its composed nodes."""
        node = self.get_single_node()
        if node is None:
            return None
        check_document(node)
        return self.construct_document(node)

    def construct_sequence(self, node: Any, deep: bool = False) -> list[Any]:
        if not isinstance(node, SequenceNode):
            return super().construct_sequence(node, deep=deep)  # PyYAML's error
        out: list[Any] = []
        for child in node.value:
            if type(child) is ScalarNode:
                if child.tag == FLOAT_TAG and _FLOAT(child.value):
                    out.append(float(child.value))
                    continue
                if child.tag == INT_TAG and _INT(child.value):
                    out.append(int(child.value))
                    continue
            out.append(self.construct_object(child, deep=deep))
        return out

    def construct_number_list(self, node: Any) -> list[int | float]:
        self.built += 1
        # the list pattern took only _INT and _FLOAT tokens: a float has a dot, an int none
        tokens = _SPLIT.split(self.lists[int(node.value[len(self.mark) + 1 :])])
        return [float(t) if "." in t else int(t) for t in tokens]


_Loader.add_constructor(LIST_TAG, _Loader.construct_number_list)
_Loader.add_constructor(INT_TAG, grammar_int)


def _cut_out(text: str, mark: str) -> tuple[str, list[str]]:
    """The text with its one-line number lists replaced by ``mark_<i>``, and the lists' items."""
    items: list[str] = []

    def placeholder(match: re.Match[str]) -> str:
        items.append(match.group(1))
        return f"{mark}_{len(items) - 1}"

    return _LIST.sub(placeholder, text), items


def load(text: str) -> Any:
    """The document of ``text``, as ``yaml.load(text, Loader=CSafeLoader)`` gives it.

    Raises
    ------
    yaml.YAMLError
        As PyYAML does; :class:`.yaml_guard.DocumentError` (one) for a
        duplicate key or an alias bomb.
    """
    if len(text) < LARGE_TEXT:
        return yaml.load(text, Loader=_Loader)  # noqa: S506 - a safe loader
    mark = "pmr_ros_numbers_" + secrets.token_hex(8)
    while mark in text:
        mark = "pmr_ros_numbers_" + secrets.token_hex(8)
    cut, items = _cut_out(text, mark)
    loader = _Loader(cut)
    loader.mark, loader.lists = mark, items
    try:
        document = loader.get_single_data()
    except DocumentError:
        raise  # a duplicate key or an alias bomb in the text is one in the original too
    except yaml.YAMLError:
        document = None
    finally:
        loader.dispose()
    if document is not None and loader.built == len(items):  # every placeholder stood for a whole node
        return document
    return yaml.load(text, Loader=_Loader)  # noqa: S506 - a safe loader; PyYAML's answer or error as it is
