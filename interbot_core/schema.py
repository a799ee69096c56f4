"""Typed declarations for every wire message and file, checked by msgspec (issue 13).

A message or a configuration is declared once, as a ``msgspec.Struct`` (or a dataclass) whose
field types carry their constraints: ``Annotated[float, Meta(ge=0.0, le=5.0)]``, ``Literal``
choices, ``tuple[int, ...]`` with a ``max_length``. msgspec decodes and validates in C
(``msgspec.convert`` for already-parsed YAML/JSON, ``msgspec.json`` for bytes); this module adds
what msgspec leaves to its users:

* `explain` turns a ``msgspec.ValidationError`` into a `SchemaError` whose message names the
  field, the value received and what is allowed ("speed.seq = -1 is outside the allowed range
  0..9007199254740992", "malfunction.kind must be one of collision, other; got 'fire'"), and
  whose ``kind`` says which rule was broken (``type``, ``missing``, ``unknown``, ``range``), so
  each caller raises its own error type (the tablet protocol's error codes, a config error).
* `check_fields` validates a Struct's fields when it is *constructed* in Python (msgspec checks
  only what it decodes), so an invalid message cannot even be built; ints given for float
  fields become floats and lists given for tuple fields become tuples.
* `convert` is ``msgspec.convert`` raising `SchemaError`; `Declared` is the base of a section or
  message checked on construction, with a `Declared.check` hook for rules across fields.
* `parse_json` parses JSON text refusing NaN, bad UTF-8 and duplicate keys (msgspec keeps the
  last of duplicates); `one_of` declares a str field with fixed choices.
* `read_yaml` reads a YAML file and `load` converts it (or one of its sections) to its
  declaration, each raising the caller's error type prefixed with the file's name; `checked`
  validates one argument against a declared type (a watchdog's ceiling, a route's tolerance).

Units go in ``Meta(extra={"unit": "m/s"})`` and appear in messages. ``FINITE`` is the bound
that makes a float field refuse NaN and ±inf (msgspec has no ``allow_inf_nan`` switch).
"""

from __future__ import annotations

import contextvars
import dataclasses
import json
import math
import re
import sys
import types
import typing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any, Final, Literal

import msgspec
import yaml
from msgspec import inspect as mi

FINITE: Final = sys.float_info.max
"""``Meta(ge=-FINITE, le=FINITE)`` admits every finite float and refuses NaN and ±inf."""

Finite = typing.Annotated[float, msgspec.Meta(ge=-FINITE, le=FINITE)]
"""A finite float."""


def within(low: float, high: float, unit: str = "", *, low_open: bool = False) -> msgspec.Meta:
    """The constraint ``[low, high]`` (``(low, high]`` when ``low_open``) of a number, with the
    unit its errors name."""
    extra = {"unit": unit} if unit else None
    if low_open:
        return msgspec.Meta(gt=low, le=high, extra=extra)
    return msgspec.Meta(ge=low, le=high, extra=extra)


def one_of(*choices: str) -> msgspec.Meta:
    """The constraint of a ``str`` field that takes one of ``choices``.

    ``Annotated[str, one_of("a", "b")]`` is a str to the type checker (callers pass plain
    strings) and refuses anything else at run time; errors list the choices in this order.
    """
    pattern = "^(?:" + "|".join(map(re.escape, choices)) + ")$"
    return msgspec.Meta(pattern=pattern, extra={"one_of": choices})


ProblemKind = Literal["type", "missing", "unknown", "range"]
T = typing.TypeVar("T")


class SchemaError(ValueError):
    """Data that does not match its declaration. ``path`` is the dotted field name."""

    def __init__(self, kind: ProblemKind, path: str, message: str) -> None:
        super().__init__(message)
        self.kind: ProblemKind = kind
        self.path = path
        self.message = message

    def key_message(self) -> str:
        """The message worded for a configuration file: an unknown field is an unknown key."""
        if self.kind != "unknown":
            return self.message
        return f"unknown key '{self.path}'{self.message[self.message.find(' (allowed') :]}"


def describe(value: object) -> str:
    """A short repr of a received value for an error message (40 characters at most)."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


_DECODING: Final = contextvars.ContextVar("interbot_schema_decoding", default=False)


def convert(data: object, type_: type[T], root: str, *, strict: bool = True) -> T:
    """``msgspec.convert(data, type_)``; a mismatch raises `SchemaError` naming ``root.field``.

    While it runs, `decoding` is true: a Struct's ``__post_init__`` may then skip `check_fields`
    (msgspec has just checked every field against the same declaration).
    """
    token = _DECODING.set(True)
    try:
        return msgspec.convert(data, type_, strict=strict)
    except msgspec.ValidationError as exc:
        raise explain(exc, data, type_, root) from None
    finally:
        _DECODING.reset(token)


def decoding() -> bool:
    """True inside `convert`: the Struct being built comes from msgspec, already checked."""
    return _DECODING.get()


def checked(value: object, type_: Any, path: str, error: type[Exception] = ValueError) -> Any:
    """``value`` converted to the declared ``type_`` (``Annotated[float, Meta(gt=0)]`` ...);
    a mismatch raises ``error`` naming ``path``, the value and what is allowed."""
    try:
        return convert(value, type_, path)
    except SchemaError as exc:
        raise error(exc.message) from None


# --------------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------------


def read_yaml(path: str | Path, error: type[Exception], what: str) -> Any:
    """The parsed YAML of the ``what`` file at ``path``. An unreadable file or invalid YAML
    raises ``error`` naming the file: "robot.yaml: cannot read the robot configuration (No such
    file or directory)", "robot.yaml: invalid YAML (...)"."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise error(f"{path}: cannot read the {what} ({exc.strerror or exc})") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise error(f"{path}: invalid YAML ({exc})") from None


def load(data: object, type_: type[T], root: str, source: str, error: type[Exception]) -> T:
    """``data`` (parsed YAML) as ``type_``, its fields checked and its `Declared.check` rules
    run; a problem raises ``error`` as "SOURCE: ROOT.key ..." (an unknown field is an unknown
    key, see `SchemaError.key_message`)."""
    try:
        value = convert(data, type_, root)
        check_all(value)
    except SchemaError as exc:
        raise error(f"{source}: {exc.key_message()}") from None
    except error as exc:
        raise error(f"{source}: {exc}") from None
    return value


# --------------------------------------------------------------------------------------------
# JSON text
# --------------------------------------------------------------------------------------------

_JSON: Final = msgspec.json.Decoder()
_JSON_OUT: Final = msgspec.json.Encoder()


class JsonSyntaxError(ValueError):
    """Bytes that are not one JSON value: bad UTF-8, NaN, a duplicate key, too deep, ..."""


def _reject_constant(name: str) -> object:
    raise ValueError(f"{name} is not valid JSON")


def _pairs_without_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    obj: dict[str, Any] = {}
    for key, value in pairs:
        if key in obj:
            raise ValueError(f"duplicate key {key!r}")
        obj[key] = value
    return obj


def _strict_loads(data: bytes) -> object:
    return json.loads(
        data.decode("utf-8"),
        parse_constant=_reject_constant,
        object_pairs_hook=_pairs_without_duplicates,
    )


def parse_json(data: bytes) -> object:
    """Parse one JSON value, refusing NaN/Infinity and duplicate keys; raise `JsonSyntaxError`.

    msgspec parses; it keeps the last of duplicate keys, so what it kept is encoded again and
    the colons counted: outside strings each colon is one key, and colons inside strings are
    kept as they are, so a duplicate shows as a missing colon. When the counts differ, or the
    text has ``\\u`` escapes (an escaped colon would hide a dropped one), the text is parsed
    again by the standard library, told to refuse duplicates. The standard library also
    words the error for text msgspec refuses ("NaN is not valid JSON").
    """
    try:
        try:
            value = _JSON.decode(data)
        except msgspec.DecodeError:
            value = _strict_loads(data)  # raises the error a person can act on
        if b"\\u" in data or _JSON_OUT.encode(value).count(b":") != data.count(b":"):
            value = _strict_loads(data)
    except UnicodeDecodeError as exc:
        raise JsonSyntaxError(f"not valid UTF-8 ({exc.reason} at byte {exc.start})") from None
    except RecursionError:
        raise JsonSyntaxError("nested too deeply") from None
    except ValueError as exc:
        raise JsonSyntaxError(f"not valid JSON: {exc}") from None
    return value


# --------------------------------------------------------------------------------------------
# Error messages
# --------------------------------------------------------------------------------------------

_ERROR = re.compile(r"^(?P<what>.*?)(?: - at (?P<key>`key` in )?`\$(?P<path>[^`]*)`)?$", re.DOTALL)
_TOKEN = re.compile(r"\.([^.\[]+)|\[(\d+|\.\.\.)\]")
_BOUND = re.compile(r"^Expected `(?P<type>\w+)`(?: of length)? (?P<op>[<>]=?) ")
_FIELD = re.compile(r"field `(?P<name>[^`]+)`")


def explain(exc: msgspec.ValidationError, data: object, type_: Any, root: str) -> SchemaError:
    """The `SchemaError` for msgspec's ``exc`` raised while converting ``data`` to ``type_``."""
    match = _ERROR.match(str(exc))
    assert match is not None  # the pattern matches every string
    what, raw_path = match["what"], match["path"] or ""
    tokens: list[str | int] = []
    for name, index in _TOKEN.findall(raw_path):
        if index == "...":  # a value of a dict: find which
            bad = _bad_entry(data, type_, tokens, key=False)
            if bad is None:
                break
            tokens.append(bad)
        else:
            tokens.append(name if name else int(index))
    if match["key"]:  # a key of a dict
        bad = _bad_entry(data, type_, tokens, key=True)
        where = _join(root, tokens)
        rule = what.removeprefix("Expected ").replace("`", "")
        return SchemaError("type", where, f"{where} key {describe(bad)} must be a {rule}")
    path = _join(root, tokens)
    value = _value_at(data, tokens)
    at = _type_info(_hint_at(type_, tokens))  # the field's declared type, Meta included
    info = _unwrap(at)
    if what.startswith("Object missing required field") or what.startswith(
        "Object contains unknown field"
    ):
        return _field_problem(what, value, info, path)
    unit = _unit(at)
    choices = _extra(at, "one_of")
    if choices:  # a wrong type or a string outside them: either way, say the choices
        allowed = ", ".join(choices)
        return SchemaError("type", path, f"{path} must be one of {allowed}; got {describe(value)}")
    form = _extra(at, "format")
    if isinstance(info, mi.StrType) and what.startswith("Expected `str` matching"):
        form = form or f"a string matching {info.pattern}"
        return SchemaError("type", path, f"{path} must be {form}, got {describe(value)}")
    if what.startswith("Invalid enum value") and isinstance(info, mi.LiteralType):
        allowed = ", ".join(map(str, _declared_literal(type_, tokens) or info.values))
        return SchemaError("type", path, f"{path} must be one of {allowed}; got {describe(value)}")
    bound = _BOUND.match(what)
    if bound is not None:
        return _bound_problem(value, _member_for(info, value), path, unit)
    expected = form or _expected(info, unit)
    where = path or "the document"
    return SchemaError("type", path, f"{where} must be {expected}, got {describe(value)}")


def _join(root: str, tokens: Sequence[str | int]) -> str:
    path = root + "".join(f"[{t}]" if isinstance(t, int) else f".{t}" for t in tokens)
    return path.removeprefix(".") if not root else path


def _field_problem(what: str, value: object, info: mi.Type, path: str) -> SchemaError:
    """A missing or unknown field; a missing one is named first, whichever msgspec met first."""
    fields = info.fields if isinstance(info, mi.StructType | mi.DataclassType) else ()
    names = [f.encode_name for f in fields]
    required = [f.encode_name for f in fields if f.required]
    present = value if isinstance(value, Mapping) else {}
    missing = [n for n in required if n not in present]
    whole = path or "the document"
    if missing:
        where = f"{path}.{missing[0]}" if path else missing[0]
        return SchemaError(
            "missing", where, f"{where} is missing ({whole} needs {', '.join(required)})"
        )
    found = _FIELD.search(what)
    where = (
        f"{path}.{found['name'] if found else '?'}" if path else (found["name"] if found else "?")
    )
    return SchemaError(
        "unknown", where, f"{where} is not a field of {whole} (allowed: {', '.join(names)})"
    )


def _bound_problem(value: object, info: mi.Type, path: str, unit: str) -> SchemaError:
    units = f" {unit}" if unit else ""
    if isinstance(info, mi.FloatType) and isinstance(value, float) and not math.isfinite(value):
        unit_text = f" [{unit}]" if unit else ""
        return SchemaError(
            "type", path, f"{path} must be a finite number{unit_text}, got {value!r}"
        )
    if isinstance(info, mi.IntType | mi.FloatType):
        return SchemaError(
            "range",
            path,
            f"{path} = {describe(value)}{units} is outside the allowed range {_range(info, unit)}",
        )
    if isinstance(value, str):
        low, high = getattr(info, "min_length", None), getattr(info, "max_length", None)
        return SchemaError(
            "range", path, f"{path} has {len(value)} characters; {_length(low, high)} are allowed"
        )
    length = len(value) if isinstance(value, Sequence | Mapping) else 0
    low, high = getattr(info, "min_length", None), getattr(info, "max_length", None)
    return SchemaError(
        "range", path, f"{path} has {length} elements; {_length(low, high)} are allowed"
    )


def _member_for(info: mi.Type, value: object) -> mi.Type:
    """The member of a union that ``value``'s JSON kind belongs to (the one whose bound broke)."""
    if not isinstance(info, mi.UnionType):
        return info
    kinds = {
        bool: mi.BoolType,
        int: mi.IntType,
        float: mi.FloatType,
        str: mi.StrType,
        list: mi.ListType | mi.VarTupleType | mi.TupleType,
        dict: mi.DictType | mi.StructType,
    }
    wanted = kinds.get(type(value))
    for member in map(_unwrap, info.types):
        if wanted is not None and isinstance(member, wanted):
            return member
    return info


def _length(low: int | None, high: int | None) -> str:
    if low is not None and high is not None:
        return f"{low}..{high}"
    return f"at least {low}" if low is not None else f"at most {high}"


def _range(info: mi.IntType | mi.FloatType, unit: str = "") -> str:
    """``0..10`` for integers, ``[-0.5, 0.5] m/s`` for numbers (open ends as ``(0, inf)``)."""
    low = info.ge if info.ge is not None else info.gt
    high = info.le if info.le is not None else info.lt
    if isinstance(info, mi.IntType) and info.gt is None and info.lt is None:
        return f"{'-inf' if low is None else low}..{'inf' if high is None else high}"

    def show(x: float | None, default: str) -> str:
        return default if x is None or abs(x) == FINITE else f"{x:g}"

    opening = "[" if info.ge is not None and abs(info.ge) != FINITE else "("
    closing = "]" if info.le is not None and abs(info.le) != FINITE else ")"
    text = f"{opening}{show(low, '-inf')}, {show(high, 'inf')}{closing}"
    return f"{text} {unit}" if unit else text


def _expected(info: mi.Type, unit: str = "") -> str:
    """What a value of ``info`` looks like, in words."""
    units = f" [{unit}]" if unit else ""
    if isinstance(info, mi.IntType):
        low = info.ge if info.ge is not None else info.gt
        if low is not None or info.le is not None or info.lt is not None:
            return f"an integer in {_range(info)}"
        return "an integer"
    if isinstance(info, mi.FloatType):
        return f"a number{units}"
    if isinstance(info, mi.BoolType):
        return "true or false"
    if isinstance(info, mi.StrType):
        return "a string"
    if isinstance(info, mi.LiteralType):
        return "one of " + ", ".join(map(str, info.values))
    if isinstance(info, mi.StructType | mi.DataclassType):
        return "an object with keys " + ", ".join(f.encode_name for f in info.fields)
    if isinstance(info, mi.TupleType):
        return f"an array of {len(info.item_types)} elements"
    if isinstance(info, mi.VarTupleType | mi.ListType):
        return "an array"
    if isinstance(info, mi.DictType):
        return "an object"
    if isinstance(info, mi.UnionType):
        return " or ".join(_expected(_unwrap(t)) for t in info.types)
    if isinstance(info, mi.NoneType):
        return "null"
    return type(info).__name__.removesuffix("Type").lower()


def _type_info(type_: Any) -> mi.Type:
    """msgspec's view of a declared type (Any where the walk could not tell)."""
    return mi.type_info(Any if type_ is None else type_)


def _unwrap(info: mi.Type) -> mi.Type:
    while isinstance(info, mi.Metadata):
        info = info.type
    if isinstance(info, mi.UnionType):  # Optional[X] is described as X
        others = [t for t in info.types if not isinstance(t, mi.NoneType)]
        if len(others) == 1:
            return _unwrap(others[0])
    return info


def _unit(info: mi.Type) -> str:
    return str(_extra(info, "unit") or "")


def _extra(info: mi.Type, name: str) -> Any:
    """Entry ``name`` of the ``Meta(extra=...)`` of a field type (looking inside ``X | None``)."""
    while True:
        if isinstance(info, mi.Metadata):
            if info.extra and name in info.extra:
                return info.extra[name]
            info = info.type
        elif isinstance(info, mi.UnionType):
            others = [t for t in info.types if not isinstance(t, mi.NoneType)]
            if len(others) != 1:
                return None
            info = others[0]
        else:
            return None


def _strip(hint: Any) -> Any:
    """``X`` of ``Annotated[X, ...]`` and of ``X | None``."""
    while True:
        origin = typing.get_origin(hint)
        if origin is typing.Annotated:
            hint = typing.get_args(hint)[0]
        elif origin in (typing.Union, types.UnionType):
            others = [a for a in typing.get_args(hint) if a is not type(None)]
            if len(others) != 1:
                return hint
            hint = others[0]
        else:
            return hint


def _hint_at(type_: Any, tokens: Sequence[str | int]) -> Any:
    """The declared Python type at ``tokens`` inside ``type_`` (None when it cannot be told)."""
    hint = type_
    for token in tokens:
        hint = _strip(hint)
        origin = typing.get_origin(hint)
        if isinstance(hint, type) and issubclass(hint, msgspec.Struct):
            hint = {f.encode_name: f.type_ for f in _fields(hint)}.get(str(token))
        elif dataclasses.is_dataclass(hint):
            hint = typing.get_type_hints(hint, include_extras=True).get(str(token))
        elif origin is dict:
            hint = typing.get_args(hint)[1]
        elif origin is tuple and typing.get_args(hint)[-1:] != (Ellipsis,):
            args = typing.get_args(hint)
            hint = args[token] if isinstance(token, int) and token < len(args) else None
        elif origin in (tuple, list, frozenset, set):
            hint = typing.get_args(hint)[0]
        else:
            return None
    return hint


def _declared_literal(type_: Any, tokens: Sequence[str | int]) -> tuple[object, ...]:
    """The values of the ``Literal`` at ``tokens`` in declaration order (msgspec sorts them)."""
    hint = _strip(_hint_at(type_, tokens))
    return typing.get_args(hint) if typing.get_origin(hint) is Literal else ()


def _bad_entry(data: object, type_: Any, tokens: list[str | int], key: bool) -> str | None:
    """The first key (``key``) or the key of the first value of the dict at ``tokens`` that
    does not convert to its declared type: msgspec's path says only ``[...]``."""
    mapping = _value_at(data, tokens)
    hint = _strip(_hint_at(type_, tokens))
    if not isinstance(mapping, Mapping) or typing.get_origin(hint) is not dict:
        return None
    key_type, value_type = typing.get_args(hint)
    for k, v in mapping.items():
        try:
            msgspec.convert(k if key else v, key_type if key else value_type, strict=True)
        except msgspec.ValidationError:
            return str(k)
    return None


def _value_at(data: object, tokens: Sequence[str | int]) -> object:
    for token in tokens:
        if isinstance(token, int) and isinstance(data, Sequence) and not isinstance(data, str):
            data = data[token] if token < len(data) else None
        elif isinstance(data, Mapping):
            data = data.get(token)
        else:
            data = getattr(data, str(token), None)
    return data


# --------------------------------------------------------------------------------------------
# Construction-time checks
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Field:
    name: str
    encode_name: str
    type_: Any
    text: bool  # a str field (checked for lone surrogates, which msgspec.convert lets through)


@cache
def _fields(cls: type[msgspec.Struct]) -> tuple[_Field, ...]:
    hints = typing.get_type_hints(cls, include_extras=True)
    info = _type_info(cls)
    assert isinstance(info, mi.StructType)
    return tuple(
        _Field(f.name, f.encode_name, hints[f.name], isinstance(_unwrap(f.type), mi.StrType))
        for f in info.fields
    )


@cache
def _checker(cls: type[msgspec.Struct]) -> type[msgspec.Struct]:
    """A twin of ``cls`` without its ``__post_init__``, to check an instance in one C call."""
    return msgspec.defstruct(f"{cls.__name__}Check", [(f.name, f.type_) for f in _fields(cls)])


def check_fields(obj: msgspec.Struct, root: str, *, bare: bool = False) -> None:
    """Validate every field of a Struct built in Python against its declared type.

    Raises `SchemaError` naming ``root.field`` (``root`` alone when ``bare``). Values are
    normalised in place (an int for a float field becomes a float, a list for a tuple field a
    tuple), so that equal messages encode alike and frozen ones stay hashable.
    """
    fields = _fields(type(obj))
    try:
        checked = msgspec.convert(obj, _checker(type(obj)), from_attributes=True, strict=True)
    except msgspec.ValidationError:
        for f in fields:  # find the field again, to word the error as a decoded one would be
            value = getattr(obj, f.name)
            path = root if bare else f"{root}.{f.encode_name}" if root else f.encode_name
            convert(value, f.type_, path)
        raise  # pragma: no cover - the loop raises
    values, normal = msgspec.structs.astuple(obj), msgspec.structs.astuple(checked)
    for i in _text_fields(type(obj)):
        check_text(values[i], root if bare else f"{root}.{fields[i].encode_name}")
    if values != normal or list(map(type, values)) != list(map(type, normal)):
        for f, value, new in zip(fields, values, normal, strict=True):
            if type(new) is not type(value):
                msgspec.structs.force_setattr(obj, f.name, new)


@cache
def _text_fields(cls: type[msgspec.Struct]) -> tuple[int, ...]:
    return tuple(i for i, f in enumerate(_fields(cls)) if f.text)


class Declared(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """Base of a declared configuration section or message checked on construction.

    Built in Python, its fields are checked (`check_fields`, naming ``ROOT.field``) and then
    `check` runs (rules relating fields); a failure raises ``ERROR``. Converted by msgspec (in
    `convert`), the fields are already checked: call `check_all` on the result for the rules.
    """

    ROOT: typing.ClassVar[str] = ""
    ERROR: typing.ClassVar[type[Exception]] = SchemaError

    def __post_init__(self) -> None:
        if decoding():
            return
        try:
            check_fields(self, self.ROOT)
        except SchemaError as exc:
            raise self.ERROR(exc.message) from None
        self.check()

    def check(self) -> None:
        """Rules across fields; raise ``ERROR``."""


def check_all(obj: object) -> None:
    """Run `Declared.check` on ``obj`` and on every Declared inside it (after `convert`)."""
    if isinstance(obj, msgspec.Struct):
        for value in msgspec.structs.astuple(obj):
            check_all(value)
        if isinstance(obj, Declared):
            obj.check()
    elif isinstance(obj, tuple | list):
        for value in obj:
            check_all(value)


def check_text(value: object, path: str) -> None:
    """Refuse lone UTF-16 surrogates (legal in a JSON escape, not encodable as UTF-8)."""
    if isinstance(value, str) and not value.isascii():
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            raise SchemaError("type", path, f"{path} contains a lone UTF-16 surrogate") from None
