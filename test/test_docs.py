"""The README and the docs/ pages name only what exists, and the README stays short.

Every backticked span and every relative Markdown link of README.md and
docs/*.md is read (fenced code blocks are left out: they show commands and
output, not references). A token that looks like a repository path (a file
name with an extension, or a path whose first folder is a top-level entry of
the repository) must exist, relative to the repository or to the page; a
dotted ``pmr_ros.x.y`` name must be a module or package of pmr_ros, or a name
defined at the top of one. What cannot exist in a clone — generated outputs,
names of other trees — is listed in ``IGNORED`` with the reason.
"""

from __future__ import annotations

import ast
import importlib
import os
import re
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
README_MAX_LINES = 250

# Top-level entries that a path may start with (hidden ones included: .ci/run).
TOP_LEVEL = {p.name for p in ROOT.iterdir()} - {".git"}
EXTENSIONS = (".py", ".yaml", ".yml", ".md", ".sh", ".toml", ".cfg", ".xml", ".png", ".csv", ".json", ".html", ".txt")

# prefix or exact token -> why it cannot be checked against the clone
IGNORED: dict[str, str] = {
    "data.csv": "a user's data file in an error message quoted by docs/limits.md",
    "runs/": "outputs the walkthrough's commands write (not in the repository)",
    "rosdep/": "files of the ros/rosdistro repository, where the rosdep keys were checked",
    "jazzy/": "files of the ros/rosdistro repository, where the rosdep keys were checked",
    "results.csv": "written by pmr-ros sweep into its output folder",
    "export.csv": "a user's historian export in an example command",
}

SPAN = re.compile(r"(?<!`)`([^`\n]+)`(?!`)")
LINK = re.compile(r"\]\(([^)\s]+)\)")
MODULE = re.compile(r"\bpmr_ros(?:\.[A-Za-z_]\w*)+")
FENCE = re.compile(r"^```.*?^```", re.DOTALL | re.MULTILINE)


def _prose(page: Path) -> str:
    """The page's text without its fenced code blocks."""
    return FENCE.sub("", page.read_text(encoding="utf-8"))


def _ignored(token: str) -> bool:
    return any(token == key or (key.endswith("/") and token.startswith(key)) for key in IGNORED)


def _is_path(token: str) -> bool:
    """Whether a token names a file or folder of the repository (not a topic, an option or a URL)."""
    if not token or "://" in token or (token[0] in "-/~$<." and not token.startswith(".ci/")):
        return False
    if any(char in token for char in "*<>{}…|=,:'\"()[]") or token.startswith("../") or "..." in token:
        return False
    head = token.split("/", 1)[0]
    return ("/" in token and head in TOP_LEVEL) or token.rstrip("/").endswith(EXTENSIONS)


def _named_all(page: Path) -> tuple[set[str], set[str]]:
    """The repository paths (ignored ones included) and the dotted module names a page names."""
    text = _prose(page)
    paths, modules = set(), set()
    for span in SPAN.findall(text):
        modules.update(MODULE.findall(span))
        paths.update(token.strip(".;:") for token in span.split() if _is_path(token.strip(".;:")))
    for target in LINK.findall(text):
        target = target.split("#", 1)[0]
        if target and "://" not in target and not target.startswith("mailto:"):
            paths.add(target)
    return paths, modules


def _named(page: Path) -> tuple[set[str], set[str]]:
    """The repository paths and the dotted module names a page names, less the ignored ones."""
    paths, modules = _named_all(page)
    return {p for p in paths if not _ignored(p)}, modules


@cache
def _file_names() -> frozenset[str]:
    names: set[str] = set()
    for _folder, subfolders, files in os.walk(ROOT):
        subfolders[:] = [d for d in subfolders if d not in {".git", ".venv", "__pycache__", "build", "install"}]
        names.update(files)
    return frozenset(names)


def _exists(path: str, page: Path) -> bool:
    if (ROOT / path).exists() or (page.parent / path).exists():
        return True
    # A bare file name (`qp.py`) must be some file of the repository.
    return "/" not in path.rstrip("/") and path.rstrip("/") in _file_names()


def _top_level_names(source: Path) -> set[str]:
    names = set()
    for node in ast.parse(source.read_text(encoding="utf-8")).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names.update(t.id for t in targets if isinstance(t, ast.Name))
            # A package front file that loads its names on first use lists them in __all__.
            if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets) and node.value is not None:
                names.update(c.value for c in ast.walk(node.value) if isinstance(c, ast.Constant))
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((alias.asname or alias.name).split(".")[0] for alias in node.names)
    return names


def _module_file(parts: list[str]) -> Path | None:
    base = ROOT.joinpath(*parts)
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _module_exists(dotted: str) -> bool:
    """A module or package of pmr_ros, or a name defined at the top of one (`pmr_ros.simulate`)."""
    parts = dotted.split(".")
    if _module_file(parts) is not None:
        return True
    owner = _module_file(parts[:-1])
    if owner is None:
        return False
    if parts[-1] in _top_level_names(owner):
        return True
    # A front file that loads its names on first use (module __getattr__): ask the module itself.
    return hasattr(importlib.import_module(".".join(parts[:-1])), parts[-1])


def _missing(page: Path) -> list[str]:
    paths, modules = _named(page)
    gone = [p for p in sorted(paths) if not _exists(p, page)]
    gone += [m for m in sorted(modules) if not _module_exists(m)]
    return gone


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_named_path_and_module_exists(page):
    missing = _missing(page)
    assert missing == [], f"{page.relative_to(ROOT)} names what does not exist: {missing}"


def test_every_ignored_name_is_named_somewhere():
    named = set().union(*(_named_all(page)[0] for page in PAGES))
    unused = [key for key in IGNORED if not any(p == key or (key.endswith("/") and p.startswith(key)) for p in named)]
    assert unused == [], f"IGNORED entries no page names any more (drop them): {unused}"


def test_readme_is_short():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").count("\n")
    assert lines <= README_MAX_LINES, f"README.md has {lines} lines, at most {README_MAX_LINES}"


def test_the_checker_finds_a_stale_name(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "The model is in `foptd.py` and `pmr_ros/core/foptd.py`, read by `pmr_ros.core.nowhere`;\n"
        "topics like `pmr/setpoint`, options like `--json` and outputs like `runs/report/` are no paths.\n"
        "See [the theory](nowhere.md).\n```\ncode/blocks.py are not read\n```\n",
        encoding="utf-8",
    )
    assert _missing(page) == ["foptd.py", "nowhere.md", "pmr_ros/core/foptd.py", "pmr_ros.core.nowhere"]


def test_the_checker_accepts_what_exists(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "`config/wood_berry.yaml`, `test/test_docs.py`, `pmr_ros/`, `pyproject.toml`, `.ci/run`, "
        "`pmr_ros.cli`, `pmr_ros.cli.main`, [the README](README.md)\n",
        encoding="utf-8",
    )
    assert _missing(page) == []
