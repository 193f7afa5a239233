"""Reading YAML safely: ``yaml.safe_load`` semantics, duplicate keys rejected, YAML 1.2 floats,
and bounds on size, nesting and alias expansion checked before anything is built. Every error is a
:class:`ConfigError` with the file and line."""
from __future__ import annotations

import os
import re
import stat
from pathlib import Path
from typing import Any

import yaml

from .schema import ConfigError, printable


class _StrictLoader(yaml.SafeLoader):
    """safe_load, but a mapping with a repeated key is an error, and numbers in exponent form
    without a dot or a sign (1e3, 1.5e-3 both work; YAML 1.1 reads 1e3 as text) are numbers."""


def _construct_mapping(loader, node, deep=False):
    seen = {}
    for key_node, _ in node.value:
        if key_node.tag == "tag:yaml.org,2002:merge":
            continue        # `<<: *anchor`: the keys given here override the merged ones
        key = loader.construct_object(key_node, deep=True)
        try:
            hash(key)
        except TypeError:
            raise ConfigError("", "a mapping key must be a plain value, not a list or mapping",
                              line=key_node.start_mark.line + 1) from None
        if key in seen:
            raise ConfigError(str(key), f"duplicate key (first given on line {seen[key]})",
                              line=key_node.start_mark.line + 1)
        seen[key] = key_node.start_mark.line + 1
    return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
# YAML 1.2's floats: 1e3, 1E-3, 2.5e3 (PyYAML, following YAML 1.1, needs a dot and a sign).
_StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"))

# The same loader on libyaml's parser where PyYAML has it (a tenth of the time): a file it reads
# gives the same data; one it refuses is read again by the loader above, whose messages name more
# (the character, the alias) than libyaml's.
_FastLoader = None
if getattr(yaml, "__with_libyaml__", False):
    class _FastLoader(yaml.CSafeLoader):   # noqa: N801
        """_StrictLoader on libyaml's parser."""
    _FastLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
    _FastLoader.yaml_implicit_resolvers = _StrictLoader.yaml_implicit_resolvers

# Bounds on what a YAML file may make us build (a few kilobytes of aliases can expand to
# billions of nodes; thousands of brackets overflow the parser's recursion). pfbench's largest
# config, world or paper file is about 10 kB: 4 MiB is plenty.
MAX_YAML_BYTES = 4 * 2**20
MAX_YAML_DEPTH = 64
MAX_ALIAS_NODES = 100_000


def _check_shape(text: str, loader=yaml.SafeLoader) -> None:
    """Refuse YAML whose nesting is deeper than MAX_YAML_DEPTH, whose aliases expand to more than
    MAX_ALIAS_NODES nodes beyond the file's own, or that refers to itself. One pass over the
    parser's events (no recursion, nothing built); raises ConfigError with the line."""
    E = yaml.events
    stack: list[list] = []        # [anchor, expanded size] of each open collection
    sizes: dict[str, int] = {}    # anchor -> expanded size of its node
    open_anchors: set[str] = set()
    added = 0                     # nodes that aliases add

    def grow(n: int) -> None:
        if stack:
            stack[-1][1] += n

    for ev in yaml.parse(text, Loader=loader):
        line = ev.start_mark.line + 1 if ev.start_mark else None
        if isinstance(ev, (E.SequenceStartEvent, E.MappingStartEvent)):
            if len(stack) >= MAX_YAML_DEPTH:
                raise ConfigError("", f"nested deeper than {MAX_YAML_DEPTH} levels", line=line)
            stack.append([ev.anchor, 1])
            if ev.anchor:
                open_anchors.add(ev.anchor)
        elif isinstance(ev, (E.SequenceEndEvent, E.MappingEndEvent)):
            anchor, n = stack.pop()
            if anchor:
                sizes[anchor] = n
                open_anchors.discard(anchor)
            grow(n)
        elif isinstance(ev, E.ScalarEvent):
            if ev.anchor:
                sizes[ev.anchor] = 1
            grow(1)
        elif isinstance(ev, E.AliasEvent):
            if ev.anchor in open_anchors:
                raise ConfigError("", f"the alias *{ev.anchor} refers to a node that contains it",
                                  line=line)
            n = sizes.get(ev.anchor, 1)     # an undefined alias: the loader names it
            added += n
            if added > MAX_ALIAS_NODES:
                raise ConfigError("", f"aliases (*{ev.anchor}) expand to more than "
                                  f"{MAX_ALIAS_NODES:,} values", line=line)
            grow(n)


def _lines(node, path="", out=None) -> dict[str, int]:
    """Map each key path ("filters.pf.particles") to its line number in the file (each node is
    walked where it is written; an alias's contents are not walked again)."""
    out = {} if out is None else out
    stack = [(node, path)]
    seen: set[int] = set()
    while stack:
        node, path = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        if isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                p = f"{path}.{k.value}" if path else str(k.value)
                out.setdefault(p, k.start_mark.line + 1)
                stack.append((v, p))
        elif isinstance(node, yaml.SequenceNode):
            for i, v in enumerate(node.value):
                p = f"{path}[{i}]"
                out.setdefault(p, v.start_mark.line + 1)
                stack.append((v, p))
    return out


def _load(text: str, loader_class) -> tuple[Any, dict[str, int]]:
    """(data, line numbers by key path) of ``text`` read by ``loader_class``, its shape checked
    first (_check_shape)."""
    _check_shape(text, loader_class)
    loader = loader_class(text)
    try:
        node = loader.get_single_node()
        data = loader.construct_document(node) if node is not None else None
    finally:
        loader.dispose()
    return data, (_lines(node) if node is not None else {})


def parse_yaml(text: str, source: str) -> tuple[Any, dict[str, int]]:
    """(data, line numbers by key path) of YAML ``text``; errors are ConfigErrors of ``source``."""
    if len(text) > MAX_YAML_BYTES:
        raise ConfigError("", f"larger than {MAX_YAML_BYTES // 2**20} MiB: not a config",
                          source=source)
    if _FastLoader is not None:
        try:
            return _load(text, _FastLoader)
        except Exception:       # refused: the pure-Python loader says why, in its words
            pass
    try:
        return _load(text, _StrictLoader)
    except ConfigError as err:
        raise ConfigError(err.path, err.message, source=source, line=err.line) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ConfigError("", f"not valid YAML: {problem}", source=source,
                          line=mark.line + 1 if mark else None) from None
    except (RecursionError, MemoryError):
        raise ConfigError("", "too deeply nested or too large to read", source=source) from None


def read_regular(path: str | Path, limit: int = MAX_YAML_BYTES) -> bytes:
    """The bytes of the regular file ``path``, at most ``limit`` of them; a folder, a FIFO, a
    device (/dev/zero), a socket or a larger file is a ConfigError naming it. Nothing blocks: the
    file is opened without waiting for a writer, and its type is checked on what was opened (not
    on a name that could change in between) before a byte is read."""
    shown = show_path(path)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        raise ConfigError("", "no such file", source=shown) from None
    except IsADirectoryError:
        raise ConfigError("", "is a folder, not a YAML file", source=shown) from None
    except OSError as exc:
        raise ConfigError("", f"cannot read: {exc.strerror or exc}", source=shown) from None
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise ConfigError("", "is a folder, not a YAML file", source=shown)
        if not stat.S_ISREG(st.st_mode):
            kind = ("a FIFO (named pipe)" if stat.S_ISFIFO(st.st_mode) else
                    "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else
                    "a socket" if stat.S_ISSOCK(st.st_mode) else "not a plain file")
            raise ConfigError("", f"is {kind}, not a regular file: pfbench reads only files",
                              source=shown)
        too_large = ConfigError("", f"larger than {limit // 2**20} MiB: not a config",
                                source=shown)
        if st.st_size > limit:
            raise too_large
        chunks, total = [], 0
        while True:                 # a file that grows while read is cut at the limit
            chunk = os.read(fd, min(2**20, limit + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > limit:
                raise too_large
        return b"".join(chunks)
    except OSError as exc:
        raise ConfigError("", f"cannot read: {exc.strerror or exc}", source=shown) from None
    finally:
        os.close(fd)


def show_path(path: str | Path) -> str:
    """``path`` as text that can always be printed and stored (UTF-8): a name with bytes that
    are not UTF-8 shows them as \\xNN escapes."""
    text = os.fspath(path)
    return printable(os.fsdecode(text) if isinstance(text, bytes) else text)


def read_yaml(path: str | Path) -> tuple[Any, dict[str, int]]:
    """Return (data, line numbers by key path) of a YAML file, rejecting duplicate keys and
    files that are not regular files, not UTF-8 text, too large, too deep, or whose aliases
    expand too far."""
    data = read_regular(path)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError("", f"not UTF-8 text (byte {exc.start})", source=show_path(path)) \
            from None
    return parse_yaml(text, show_path(path))
