"""Reading YAML a user gives us (scenario, sweep and model files, ``--set`` values) without surprises.

- The file is checked before parsing: it must exist and be a regular file, at most ``file_mb`` MB
  (:mod:`suspension_sim.limits`), UTF-8 text (a Latin-1 or binary file is refused with the offending byte).
- The document is composed into nodes first and its size *after alias expansion* is counted (``&a``/``*a``
  anchors make a 1 KB file stand for billions of nodes, which pydantic and ``deepcopy`` would then walk):
  more than ``yaml_nodes`` nodes, or nesting deeper than ``yaml_depth`` (or a recursive alias), is refused.
- Only the safe tags (no ``!!python/...``); duplicate keys in one mapping are refused (YAML says they are an
  error; PyYAML keeps the last silently); ``1e3`` is a number (YAML 1.1 would make it the string "1e3").

Every refusal is a one-line :class:`~suspension_sim.errors.ScenarioError` naming the file, the line where
there is one, and the limit and how to raise it where a limit was hit.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from . import limits
from .errors import ScenarioError

_Base = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class _Refused(Exception):
    """Raised inside the loader; turned into a ScenarioError with the source by the callers."""


class SafeLoader(_Base):
    """SafeLoader refusing duplicate keys (numbers like ``1e3`` read as floats)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen: dict = {}
            for knode, _ in node.value:
                if knode.tag == "tag:yaml.org,2002:merge" or not isinstance(knode, yaml.ScalarNode):
                    continue
                key = self.construct_object(knode)
                try:
                    if key in seen:
                        raise yaml.constructor.ConstructorError(
                            None, None, f"duplicate key {key!r} (first given at line {seen[key] + 1})",
                            knode.start_mark)
                    seen[key] = knode.start_mark.line
                except TypeError:  # an unhashable key: the base constructor reports it
                    pass
        return super().construct_mapping(node, deep)


SafeLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"))


def _expanded_size(root, max_nodes: float, max_depth: float) -> int:
    """Nodes of the document with every alias expanded (memoised per node: linear in the composed size)."""
    memo: dict[int, int] = {}

    def size(node, depth):
        if depth > max_depth:
            raise _Refused(f"YAML nested deeper than {int(max_depth)} levels (or a recursive alias); "
                           f"{limits.how_to_raise('yaml_depth')}")
        k = id(node)
        if k in memo:
            return memo[k]
        if isinstance(node, yaml.ScalarNode):
            n = 1
        elif isinstance(node, yaml.SequenceNode):
            n = 1
            for c in node.value:
                n += size(c, depth + 1)
                if n > max_nodes:
                    break
        else:
            n = 1
            for kn, vn in node.value:
                n += size(kn, depth + 1) + size(vn, depth + 1)
                if n > max_nodes:
                    break
        if n > max_nodes:
            raise _Refused(f"YAML expands to more than {int(max_nodes)} nodes (alias expansion: &anchor/*alias); "
                           f"{limits.how_to_raise('yaml_nodes')}")
        memo[k] = n
        return n

    return size(root, 0)


def loads(text: str, source: str | None = None, field: str | None = None) -> Any:
    """Parse YAML text safely (see the module doc); errors name ``source`` (and ``field``)."""
    loader = SafeLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _expanded_size(node, limits.get("yaml_nodes"), limits.get("yaml_depth"))
        return loader.construct_document(node)
    except _Refused as err:
        raise ScenarioError(str(err), source=source, field=field) from None
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None) or getattr(err, "context_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        ctx = getattr(err, "context", None)
        if ctx and "constructor" in str(problem):
            problem = f"{ctx}: {problem}"
        raise ScenarioError(f"not valid YAML{where}: {problem}", source=source, field=field) from None
    except RecursionError:
        raise ScenarioError(f"YAML nested too deeply; {limits.how_to_raise('yaml_depth')}", source=source,
                            field=field) from None
    finally:
        loader.dispose()


def read_text(path: str | Path, what: str = "file", limit: str = "file_mb") -> str:
    """A user's text file, checked: exists, a regular file, within the size limit, UTF-8 text."""
    p = Path(path)
    src = str(path)
    if not p.exists():
        raise ScenarioError("file not found", source=src)
    if p.is_dir():
        raise ScenarioError(f"is a directory, not a {what}", source=src)
    if not p.is_file():
        raise ScenarioError(f"not a regular file (a {what} is expected)", source=src)
    try:
        size = p.stat().st_size
    except OSError as err:
        raise ScenarioError(f"cannot read: {err.strerror}", source=src) from None
    limits.check(limit, size / 1e6, source=src, what=f"{what} size in MB")
    try:
        data = p.read_bytes()
    except OSError as err:
        raise ScenarioError(f"cannot read: {err.strerror}", source=src) from None
    return decode_text(data, src, what)


def decode_text(data: bytes, source: str, what: str = "file") -> str:
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    if b"\x00" in data[:65536]:
        raise ScenarioError(f"a binary file, not a {what} (YAML text expected)", source=source)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data[:err.start].count(b"\n") + 1
        raise ScenarioError(f"not UTF-8 text: byte 0x{data[err.start]:02x} at line {line} (a Latin-1/Windows "
                            f"file? save it as UTF-8)", source=source) from None


def load_file(path: str | Path, what: str = "scenario file") -> Any:
    """Read and parse a YAML file safely (see the module doc)."""
    return loads(read_text(path, what), source=str(path))
