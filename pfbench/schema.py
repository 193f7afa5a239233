"""Strict checking of config sections against declared keys.

A section schema is a dict ``name -> Key``. :func:`check_section` returns a plain dict with every key
of the schema (defaults filled in) or raises :class:`ConfigError` naming the key path, what was
expected and what was found, with a did-you-mean for misspelt keys and names.
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from typing import Any, Callable

from .errors import UserError

REQUIRED = object()

# Every integer key lies within int64 (a count, a step, a seed): 1e308, a whole number, would
# otherwise be an integer of 309 digits.
INT64_MAX = 2**63 - 1

# Text that Python reads as a number but YAML does not (quoted, or a form such as 'infinity').
_TEXT_HINT = "text, not a number: write it unquoted, like 1000, 2.5 or 1e3"


class ConfigError(UserError):
    """A config that does not fit its schema; ``str()`` is the one-line message.

    ``problems`` holds every problem found (itself alone for one); a config with several is
    reported as one line that counts and lists them, each with its file and line
    (:func:`gather`)."""

    def __init__(self, path: str, message: str, *, source: str = "", line: int | None = None):
        path, message, source = (printable(str(t)) for t in (path, message, source))
        self.path, self.message, self.source, self.line = path, message, source, line
        super().__init__(self._text())

    @property
    def problems(self) -> tuple["ConfigError", ...]:
        return (self,)

    def _text(self) -> str:
        where = self.source or "config"
        if self.line is not None:
            where += f":{self.line}"
        return f"{where}: {self.path}: {self.message}" if self.path else f"{where}: {self.message}"

    def located(self, source: str, lines: dict[str, int]) -> "ConfigError":
        """Return this error with the file name and the line of the key path filled in (an error
        that names its own file, a paper's or a world file's, keeps it)."""
        if self.source:
            return self
        line = self.line
        p = self.path
        while line is None and p:
            line = lines.get(p)
            p = p.rpartition(".")[0]
        return ConfigError(self.path, self.message, source=source, line=line)


class ConfigErrors(ConfigError):
    """Several problems of one config, reported at once: ``FILE: N problems: [1] FILE:LINE: KEY:
    WHAT; [2] ...`` (one line)."""

    def __init__(self, problems: list[ConfigError], source: str = ""):
        self._problems = tuple(problems)
        first = self._problems[0]
        self.path, self.source, self.line = "", source, first.line
        self.message = f"{len(problems)} problems: " + "; ".join(
            f"[{i}] {p}" for i, p in enumerate(self._problems, 1))
        UserError.__init__(self, self._text())

    @property
    def problems(self) -> tuple[ConfigError, ...]:
        return self._problems

    def _text(self) -> str:
        return f"{self.source or 'config'}: {self.message}"

    def located(self, source: str, lines: dict[str, int]) -> "ConfigError":
        """Each problem located in ``source``; those of ``source`` in the order of their lines,
        then those of other files (a paper file's)."""
        return ConfigErrors(in_order([p.located(source, lines) for p in self._problems],
                                     source), source)


def in_order(problems: list[ConfigError], source: str) -> list[ConfigError]:
    """``problems`` with those of the file ``source`` first, in the order of their lines, then
    the others (a --set's, a paper file's) in the order found."""
    order = sorted(range(len(problems)), key=lambda i: (
        problems[i].source != printable(source), problems[i].line is None, problems[i].line or 0, i))
    return [problems[i] for i in order]


def gather(problems: list[ConfigError], source: str = "") -> ConfigError:
    """One error for every problem in ``problems`` (each may hold several): the problem itself
    when there is one, else a :class:`ConfigErrors` listing them in order."""
    flat = [q for p in problems for q in p.problems]
    return flat[0] if len(flat) == 1 else ConfigErrors(flat, source)


class Problems:
    """Collects the problems of a config so that all are reported at once.

    ``with problems.attempt():`` runs a check and records its ConfigError instead of raising it;
    ``problems.ok`` says whether the block passed. ``raise_if_any()`` raises them together."""

    def __init__(self):
        self.found: list[ConfigError] = []
        self.ok = True

    def add(self, err: ConfigError) -> None:
        self.found.append(err)

    def attempt(self):
        return _Attempt(self)

    def __bool__(self) -> bool:
        return bool(self.found)

    def raise_if_any(self, source: str = "") -> None:
        if self.found:
            raise gather(self.found, source)


class _Attempt:
    def __init__(self, problems: Problems):
        self.problems = problems

    def __enter__(self):
        self.problems.ok = True
        return self.problems

    def __exit__(self, kind, exc, tb):
        if exc is not None and isinstance(exc, ConfigError):
            self.problems.add(exc)
            self.problems.ok = False
            return True
        return False


def not_utf8(text: str) -> bool:
    """Whether ``text`` holds what UTF-8 cannot write (a lone surrogate: an undecodable byte of a
    file name or an argument, as Python keeps it)."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return True
    return False


def printable(text: str) -> str:
    """``text`` with what UTF-8 cannot write shown as escapes (\\xff for an undecodable byte of a
    name): safe to print, to store in a file and to compare."""
    if not not_utf8(text):
        return text
    return text.encode("utf-8", "surrogateescape" if _only_escaped(text) else "surrogatepass") \
        .decode("utf-8", "backslashreplace")


def _only_escaped(text: str) -> bool:
    return all(not 0xD800 <= ord(c) <= 0xDFFF or 0xDC80 <= ord(c) <= 0xDCFF for c in text)


def did_you_mean(word: str, options) -> str:
    close = difflib.get_close_matches(str(word), [str(o) for o in options], n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def describe(value: Any) -> str:
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"the string '{value}'"
    if isinstance(value, (int, float)):
        return f"{value!r}"
    if value is None:
        return "nothing (null)"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, dict):
        return "a mapping"
    return type(value).__name__


def _looks_numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


# Every kind of key, with what a config may give for it (``Key.kind``).
KEY_KINDS = {
    "int": "a whole number within int64 (1e3 and 2.0 count: they are whole), within min/max",
    "float": "a finite number (an integer is taken as a float), within min/max (min_exclusive: "
             "strictly above min; max_exclusive: strictly below max)",
    "str": "a non-empty string of UTF-8 text",
    "bool": "true or false (not 0/1, not 'yes')",
    "choice": "one of the strings in choices",
    "ints": "an integer, or a list of distinct integers (each within min/max); an empty list "
            "only with empty_ok",
    "floats": "a number, or a list of numbers (each finite, within min/max); an empty list only "
              "with empty_ok",
    "names": "one of the words in words, or a list of distinct names from choices (empty "
             "allowed)",
}


@dataclass(frozen=True)
class Key:
    """One config key: of a filter type's or a scenario's schema, or of pfbench's own sections.
    ``pfbench list --keys NAME`` prints the keys of the filter or scenario NAME (plug-ins too)
    with their kinds, defaults, bounds and docs; docs/reference/config.md lists every key.

    kind : one of ``KEY_KINDS``, what a config may give:

        - 'int': a whole number within int64 (1e3 and 2.0 count), within min/max
        - 'float': a finite number, within min/max (``min_exclusive``: strictly above min,
          ``max_exclusive``: strictly below max)
        - 'str': a non-empty string of UTF-8 text
        - 'bool': true or false
        - 'choice': one of ``choices`` (strings)
        - 'ints': an integer or a list of distinct integers, each within min/max
        - 'floats': a number or a list of numbers, each finite and within min/max
        - 'names': one of ``words``, or a list of distinct names of ``choices`` (empty allowed)

        A list of 'ints' or 'floats' is validated to a tuple; an empty one only with
        ``empty_ok``. Any kind may also be null with ``nullable``.
    default : value used when the key is absent; ``REQUIRED`` if it must be given
    doc : one line for the key reference (docs/reference/config.md, from
        ``python scripts/update_readme.py --write``), for ``pfbench list --keys`` and for the
        error that names the key
    min, max : bounds for numbers (``min_exclusive``: strictly greater than min;
        ``max_exclusive``: strictly less than max)
    choices : allowed values for 'choice', the names a 'names' list may hold
    words : 'names': the words it may be instead of a list
    nullable : null (None) is allowed
    check : extra validator returning an error message or None
    empty_ok : 'ints' / 'floats': an empty list is allowed
    """

    kind: str
    default: Any = REQUIRED
    doc: str = ""
    min: float | None = None
    max: float | None = None
    min_exclusive: bool = False
    choices: tuple = ()
    nullable: bool = False
    check: Callable[[Any], str | None] | None = None
    empty_ok: bool = False      # ints / floats: an empty list is allowed
    words: tuple = ()
    max_exclusive: bool = False

    def __post_init__(self):
        if self.kind not in KEY_KINDS:
            raise ValueError(f"Key kind {self.kind!r} is none of {', '.join(KEY_KINDS)}"
                             + did_you_mean(self.kind, KEY_KINDS))

    def default_text(self) -> str:
        """The default as a config would write it: 'required', 'null', 'true', 0.5, [1, 2]."""
        d = self.default
        if d is REQUIRED:
            return "required"
        if d is None:
            return "null"
        if isinstance(d, bool):
            return str(d).lower()
        if isinstance(d, (tuple, list)):
            return "[" + ", ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in d) + "]"
        if isinstance(d, float):
            return f"{d:g}"
        return str(d)

    def expected(self) -> str:
        if self.kind == "choice":
            return "one of " + ", ".join(f"'{c}'" for c in self.choices)
        if self.kind == "names":
            return (" or ".join(f"'{w}'" for w in self.words) + " or a list of "
                    + ", ".join(f"'{c}'" for c in self.choices))
        noun = {"int": "an integer", "float": "a number", "str": "a string", "bool": "true or false",
                "ints": "an integer or a list of integers",
                "floats": "a number or a list of numbers"}[self.kind]
        bounds = []
        if self.min is not None:
            bounds.append(f"{'>' if self.min_exclusive else '>='} {self.min:g}")
        if self.max is not None:
            bounds.append(f"{'<' if self.max_exclusive else '<='} {self.max:g}")
        return noun + (" " + " and ".join(bounds) if bounds else "")

    def _range_ok(self, v) -> bool:
        if self.min is not None and (v <= self.min if self.min_exclusive else v < self.min):
            return False
        return self.max is None or (v < self.max if self.max_exclusive else v <= self.max)

    def _wrong(self, path: str, value: Any) -> ConfigError:
        msg = f"expected {self.expected()}, got {describe(value)}"
        if (isinstance(value, str) and self.kind in ("int", "float", "ints", "floats")
                and _looks_numeric(value)):
            msg += f" ({_TEXT_HINT})"
        return ConfigError(path, msg)

    def _scalar(self, path: str, value: Any, kind: str):
        if kind == "int":
            if isinstance(value, float) and math.isfinite(value) and value.is_integer():
                value = int(value)          # 1e3 or 2.0e2: a whole number written as a float
            if isinstance(value, bool) or not isinstance(value, int):
                raise self._wrong(path, value)
            if not -INT64_MAX <= value <= INT64_MAX:    # what the kernels and files hold
                raise ConfigError(path, f"expected {self.expected()}, got {describe(value)[:40]}"
                                  f"{'...' if len(describe(value)) > 40 else ''}: larger than "
                                  "2^63 - 1, the largest integer pfbench computes with")
        elif kind == "float":
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise self._wrong(path, value)
            if not math.isfinite(value):
                raise ConfigError(path, f"expected a finite number, got {value!r}")
            value = float(value)
        if kind in ("int", "float") and not self._range_ok(value):
            raise ConfigError(path, f"expected {self.expected()}, got {describe(value)}")
        return value

    def validate(self, path: str, value: Any):
        """Return the checked (and normalised) value or raise :class:`ConfigError`."""
        if value is None:
            if self.nullable:
                return None
            raise ConfigError(path, f"expected {self.expected()}, got nothing (null)")
        k = self.kind
        if k in ("int", "float"):
            value = self._scalar(path, value, k)
        elif k == "bool":
            if not isinstance(value, bool):
                raise self._wrong(path, value)
        elif k == "str":
            if not isinstance(value, str) or not value.strip():
                raise ConfigError(path, f"expected a non-empty string, got {describe(value)}")
            if not_utf8(value):
                raise ConfigError(path, f"expected UTF-8 text, got '{printable(value)}' (an "
                                  "undecodable byte)")
        elif k == "choice":
            if not isinstance(value, str) or value not in self.choices:
                raise ConfigError(path, f"expected {self.expected()}, got {describe(value)}"
                                  + did_you_mean(value, self.choices))
        elif k == "names":
            if isinstance(value, str) and value in self.words:
                return value
            if not isinstance(value, list):
                raise ConfigError(path, f"expected {self.expected()}, got {describe(value)}"
                                  + (did_you_mean(value, self.words + self.choices)
                                     if isinstance(value, str) else ""))
            for i, item in enumerate(value):
                if not isinstance(item, str) or item not in self.choices:
                    raise ConfigError(f"{path}[{i}]", "expected one of "
                                      + ", ".join(f"'{c}'" for c in self.choices)
                                      + f", got {describe(item)}"
                                      + (did_you_mean(item, self.choices)
                                         if isinstance(item, str) else ""))
            if len(set(value)) != len(value):
                raise ConfigError(path, f"expected distinct names, got {value}")
            value = tuple(value)
        elif k in ("ints", "floats"):
            items = value if isinstance(value, list) else [value]
            if not items and not self.empty_ok:
                raise ConfigError(path, f"expected {self.expected()}, got an empty list")
            out = []
            for i, item in enumerate(items):
                sub = f"{path}[{i}]" if isinstance(value, list) else path
                out.append(self._scalar(sub, item, "int" if k == "ints" else "float"))
            if k == "ints" and len(set(out)) != len(out):
                raise ConfigError(path, f"expected distinct values, got {out}")
            value = tuple(out)
        else:  # pragma: no cover - a schema bug, not a user error
            raise AssertionError(f"unknown key kind {k}")
        if self.check is not None:
            problem = self.check(value)
            if problem:
                raise ConfigError(path, problem)
        return value


def check_mapping(path: str, raw: Any) -> dict:
    if not isinstance(raw, dict):
        raise ConfigError(path, f"expected a mapping of keys, got {describe(raw)}")
    return raw


def unknown_key(path: str, name: str, valid) -> ConfigError:
    """The error for a key ``name`` that is none of ``valid``: a did-you-mean and every valid key."""
    valid = sorted(str(v) for v in valid)
    return ConfigError(path, "unknown key" + did_you_mean(name, valid)
                       + f"; valid keys: {', '.join(valid)}")


def check_section(raw: Any, schema: dict[str, Key], path: str, *, ignore: tuple = (),
                  problems: "Problems | None" = None) -> dict:
    """Validate mapping ``raw`` against ``schema``; return every schema key with defaults filled.

    ignore : further keys the section may hold, checked elsewhere (they are among the valid keys
        an unknown key's error lists)
    problems : collect every problem there instead of raising the first (a key that fails
        gets its default, or None when it has none)"""
    raw = check_mapping(path, raw)
    prefix = f"{path}." if path else ""
    found: list[ConfigError] = []
    for name in raw:
        if name not in schema and name not in ignore:
            found.append(unknown_key(f"{prefix}{name}", name, [*schema, *ignore]))
    out = {}
    for name, key in schema.items():
        try:
            if name in raw:
                out[name] = key.validate(f"{prefix}{name}", raw[name])
            elif key.default is REQUIRED:
                raise ConfigError(f"{prefix}{name}", f"missing required key ({key.expected()})")
            else:
                out[name] = key.default
        except ConfigError as err:
            found.append(err)
            out[name] = None if key.default is REQUIRED else key.default
    if found and problems is None:
        raise gather(found)
    for err in found:
        problems.add(err)
    return out
