"""The declarative schema helpers (interbot_core.schema): strict JSON, worded errors, checks."""

from __future__ import annotations

import json
import math
from typing import Annotated, Literal

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from msgspec import Meta

from interbot_core import schema
from interbot_core.schema import JsonSyntaxError, SchemaError


class Leg(msgspec.Struct, frozen=True, forbid_unknown_fields=True, rename={"to_node": "toNode"}):
    to_node: Annotated[int, Meta(ge=0, le=99)]
    speed: Annotated[float, Meta(ge=0.0, le=1.5, extra={"unit": "m/s"})]
    mode: Literal["walk", "drive"] = "drive"
    level: Annotated[str, schema.one_of("info", "warning")] = "info"
    note: str = ""

    def __post_init__(self) -> None:
        if not schema.decoding():
            schema.check_fields(self, "leg")


class Trip(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    legs: Annotated[tuple[Leg, ...], Meta(min_length=1, max_length=3)]
    tags: dict[Annotated[str, Meta(pattern="^[a-z]+$")], Annotated[int, Meta(ge=0)]] = {}
    limit: Annotated[float, Meta(gt=0.0)] | Annotated[str, Meta(max_length=3)] = 1.0


def _error(data: object, type_: type = Trip) -> SchemaError:
    with pytest.raises(SchemaError) as info:
        schema.convert(data, type_, "trip")
    return info.value


LEG = {"toNode": 3, "speed": 0.5}


@pytest.mark.parametrize(
    ("data", "kind", "path", "text"),
    [
        ({"legs": [{**LEG, "speed": 2.0}]}, "range", "trip.legs[0].speed", "= 2.0 m/s is outside the allowed range [0, 1.5] m/s"),
        ({"legs": [{**LEG, "speed": math.nan}]}, "type", "trip.legs[0].speed", "must be a finite number [m/s], got nan"),
        ({"legs": [{**LEG, "toNode": 100}]}, "range", "trip.legs[0].toNode", "= 100 is outside the allowed range 0..99"),
        ({"legs": [{**LEG, "toNode": 1.0}]}, "type", "trip.legs[0].toNode", "must be an integer in 0..99, got 1.0"),
        ({"legs": [{**LEG, "mode": "fly"}]}, "type", "trip.legs[0].mode", "must be one of walk, drive; got 'fly'"),
        ({"legs": [{**LEG, "level": "panic"}]}, "type", "trip.legs[0].level", "must be one of info, warning; got 'panic'"),
        ({"legs": [{"speed": 0.5, "to_node": 1}]}, "missing", "trip.legs[0].toNode", "is missing (trip.legs[0] needs toNode, speed)"),
        ({"legs": [{**LEG, "x": 1}]}, "unknown", "trip.legs[0].x", "is not a field of trip.legs[0] (allowed: toNode, speed, mode, level, note)"),
        ({"legs": []}, "range", "trip.legs", "has 0 elements; 1..3 are allowed"),
        ({"legs": "no"}, "type", "trip.legs", "must be an array, got 'no'"),
        ([1], "type", "trip", "must be an object with keys legs, tags, limit"),
        ({"legs": [LEG], "tags": {"ok": 1, "Bad": 2}}, "type", "trip.tags", "key 'Bad' must be a str matching"),
        ({"legs": [LEG], "tags": {"ok": 1, "no": -2}}, "range", "trip.tags.no", "= -2 is outside"),
        ({"legs": [LEG], "limit": -1.0}, "range", "trip.limit", "= -1.0 is outside the allowed range (0, inf)"),
        ({"legs": [LEG], "limit": "none"}, "range", "trip.limit", "has 4 characters; at most 3 are allowed"),
    ],
)  # fmt: skip
def test_errors_name_the_field_the_value_and_the_range(
    data: object, kind: str, path: str, text: str
) -> None:
    error = _error(data)
    assert (error.kind, error.path) == (kind, path)
    assert text in error.message and error.message.startswith(path)


def test_a_valid_document_converts() -> None:
    trip = schema.convert({"legs": [LEG], "tags": {"a": 1}}, Trip, "trip")
    assert trip == Trip((Leg(3, 0.5),), {"a": 1})


def test_construction_is_checked_and_normalised() -> None:
    leg = Leg(3, 1)  # an int for a float field
    assert isinstance(leg.speed, float)
    with pytest.raises(SchemaError, match=r"leg\.speed = 9\.0 m/s is outside"):
        Leg(3, 9.0)
    with pytest.raises(SchemaError, match=r"leg\.mode must be one of walk, drive"):
        Leg(3, 0.5, "fly")  # type: ignore[arg-type]
    with pytest.raises(SchemaError, match="surrogate"):
        Leg(3, 0.5, note="\ud800")


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (b'{"a":1,"a":2}', "duplicate key 'a'"),
        (b'{"a":{"b":1,"b":1}}', "duplicate key 'b'"),
        (b'[{"b":1},{"c":[{"d":1,"d":2}]}]', "duplicate key 'd'"),
        (b'{"a":1,"a":2,"b":"\\u003a"}', "duplicate key 'a'"),  # an escaped colon hides none
        (b'{"a":1,"a":"x:y"}', "duplicate key 'a'"),
        (b'{"a":NaN}', "NaN"),
        (b'{"a":-Infinity}', "Infinity"),
        (b'{"a":"\xff"}', "UTF-8"),
        (b'{"a":', "not valid JSON"),
        (b"[" * 100000 + b"]" * 100000, "nested too deeply"),
    ],
)
def test_parse_json_refuses(data: bytes, match: str) -> None:
    with pytest.raises(JsonSyntaxError, match=match):
        schema.parse_json(data)


def test_parse_json_keeps_colons_and_escapes_in_strings() -> None:
    data = b'{"t":"12:30 \\u00e9:","u":[{"k":"a:b"}],"v":{"w":"\\"}:"}}'
    assert schema.parse_json(data) == json.loads(data)


# Objects written by hand so that keys may repeat; strings may hold colons and escapes.
_keys = st.sampled_from(["a", "b", "c:", "\\u003a", 'd\\"e'])
_scalars = st.sampled_from(["1", "2.5", "true", "null", '"x:y"', '"\\u003a"', '""'])


def _object(children: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    pair = st.tuples(_keys, children).map(lambda kv: f'"{kv[0]}":{kv[1]}')
    return st.lists(pair, max_size=4).map(lambda ps: "{" + ",".join(ps) + "}")


_values = st.recursive(
    _scalars,
    lambda inner: _object(inner) | st.lists(inner, max_size=3).map(lambda v: f"[{','.join(v)}]"),
    max_leaves=12,
)


def _reference(text: str) -> object:
    def pairs(items: list[tuple[str, object]]) -> dict[str, object]:
        out: dict[str, object] = {}
        for k, v in items:
            if k in out:
                raise ValueError("duplicate")
            out[k] = v
        return out

    return json.loads(text, object_pairs_hook=pairs)


@settings(max_examples=300, deadline=None)
@given(text=_object(_values))
def test_parse_json_refuses_exactly_what_the_strict_reference_refuses(text: str) -> None:
    try:
        expected = _reference(text)
    except ValueError:
        with pytest.raises(JsonSyntaxError, match="duplicate"):
            schema.parse_json(text.encode())
    else:
        assert schema.parse_json(text.encode()) == expected


def test_every_wire_message_is_one_declaration() -> None:
    """Issue 13: each tablet message and zenoh JSON topic is a msgspec Struct (its types are
    its schema, also exported as JSON Schema for the recordings), not hand-written checks."""
    from interbot_core import protocol, topics

    classes = {*protocol.TABLET_MESSAGES.values(), *protocol.STATION_MESSAGES.values()}
    classes |= {s.message_type for s in topics.TOPIC_SPECS.values() if not s.binary}
    for cls in classes:
        assert issubclass(cls, msgspec.Struct), cls
        exported = msgspec.json.schema(cls)
        assert exported["$defs"][cls.__name__]["type"] == "object"


_json_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(2**70), 2**70)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=4)
        | st.dictionaries(
            st.sampled_from(["x", "id", "linear", "kind", "stops", "a"]), inner, max_size=4
        )
    ),
    max_leaves=10,
)


@settings(max_examples=300, deadline=None)
@given(body=_json_values, which=st.integers(0, 10**6))
def test_any_decoded_value_is_accepted_or_refused_with_a_protocol_or_topic_error(
    body: object, which: int
) -> None:
    """Whatever a peer sends, decoding returns a message or raises the documented error type
    with a message: the error wording code never crashes on odd paths or values."""
    from interbot_core import protocol, topics

    keys = sorted({*protocol.TABLET_MESSAGES, *protocol.STATION_MESSAGES})
    key = keys[which % len(keys)]
    for decode in (protocol.decode_tablet_message, protocol.decode_station_message):
        try:
            decode({key: body})
        except protocol.ProtocolError as exc:
            assert exc.message
    specs = [s for s in topics.TOPIC_SPECS.values() if not s.binary]
    spec = specs[which % len(specs)]
    try:
        payload = json.dumps(body).encode()
    except ValueError:
        return
    try:
        topics.decode(spec.topic, payload)
    except topics.TopicDecodeError as exc:
        assert str(exc)


class _FileError(Exception):
    pass


class _Section(schema.Declared, frozen=True):
    ROOT = "section"
    ERROR = _FileError
    low: Annotated[float, Meta(ge=0.0, le=10.0, extra={"unit": "m"})] = 1.0
    high: Annotated[float, Meta(ge=0.0, le=10.0, extra={"unit": "m"})] = 2.0

    def check(self) -> None:
        if self.low > self.high:
            raise _FileError(f"section.low ({self.low}) must be <= section.high ({self.high})")


def test_read_yaml_names_the_file_and_what_it_is(tmp_path) -> None:
    good = tmp_path / "good.yaml"
    good.write_text("section: {low: 0.5}\n", encoding="utf-8")
    assert schema.read_yaml(good, _FileError, "test file") == {"section": {"low": 0.5}}
    with pytest.raises(_FileError, match=r"nope\.yaml: cannot read the test file \(No such file"):
        schema.read_yaml(tmp_path / "nope.yaml", _FileError, "test file")
    bad = tmp_path / "bad.yaml"
    bad.write_text("section: [1\n", encoding="utf-8")
    with pytest.raises(_FileError, match=r"bad\.yaml: invalid YAML \(while parsing"):
        schema.read_yaml(bad, _FileError, "test file")


def test_load_prefixes_the_source_to_field_rule_and_unknown_key_errors() -> None:
    loaded = schema.load({"low": 0.5}, _Section, "section", "f.yaml", _FileError)
    assert (loaded.low, loaded.high) == (0.5, 2.0)
    cases = {
        "low": (
            {"low": 11},
            r"^f\.yaml: section\.low = 11 m is outside the allowed range \[0, 10\] m$",
        ),
        "rule": ({"low": 3.0}, r"^f\.yaml: section\.low \(3\.0\) must be <= section\.high"),
        "unknown": ({"wide": 1}, r"^f\.yaml: unknown key 'section\.wide' \(allowed: low, high\)"),
    }
    for data, message in cases.values():
        with pytest.raises(_FileError, match=message):
            schema.load(data, _Section, "section", "f.yaml", _FileError)


def test_checked_validates_one_argument_against_its_declared_type() -> None:
    seconds = Annotated[float, Meta(gt=0.0, le=schema.FINITE, extra={"unit": "s"})]
    assert schema.checked(2, seconds, "dog.ceiling_s") == 2.0
    with pytest.raises(ValueError, match=r"dog\.ceiling_s = 0 s is outside the allowed range"):
        schema.checked(0, seconds, "dog.ceiling_s")
    with pytest.raises(_FileError, match=r"dog\.ceiling_s must be a finite number \[s\], got nan"):
        schema.checked(math.nan, seconds, "dog.ceiling_s", _FileError)
    with pytest.raises(ValueError, match=r"dog\.ceiling_s must be a number \[s\], got True"):
        schema.checked(True, seconds, "dog.ceiling_s")
