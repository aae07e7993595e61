"""The compiled walk of uniform JSON channels (flat_json) against polars' NDJSON route.

Whatever route a channel takes, its frame must be the one ``decode_json_ndjson`` gives: the
tests compare frames exactly (names, order, dtypes, bits) on the sample logs, on random uniform
channels (hypothesis), and on channels that must fall back. The number parser is held to
``float()`` / ``int()`` bit for bit.
"""

from __future__ import annotations

import decimal
import json
import math
import random
import struct
from pathlib import Path
from typing import Any

import polars as pl
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from polars.testing import assert_frame_equal

from logtools.readers import flat_json
from logtools.readers.decoders import MAX_ARRAY_ITEMS, decode_json, decode_json_ndjson
from logtools.readers.flat_json import compiled_available, decode_uniform, parse_number
from logtools.readers.mcap_scan import Payloads, scan_mcap

ROOT = Path(__file__).resolve().parents[2]
JSON_LOGS = sorted((ROOT / "sample_logs").glob("*.mcap")) + sorted(
    (ROOT.parent / "shared" / "realworld_mcap").glob("*.mcap")
)

needs_compiled = pytest.mark.skipif(not compiled_available(), reason="extension not built")


def _route(messages: list[bytes]) -> pl.DataFrame:
    decoded = decode_json_ndjson(None, None, messages)  # type: ignore[arg-type]
    assert decoded.kept is None  # the channels here are all valid JSON
    return decoded.frame


def _same_as_route(messages: list[bytes], *, compiled: bool) -> None:
    """The compiled walk took the channel (or fell back) and decode_json equals the route."""
    expected = _route(messages)
    frame = decode_uniform(Payloads.from_bytes(messages))
    assert (frame is not None) == compiled
    if frame is not None:
        assert_frame_equal(frame, expected, check_exact=True)
    got = decode_json(None, None, messages)  # type: ignore[arg-type]
    assert got.kept is None
    assert_frame_equal(got.frame, expected, check_exact=True)


# ---------------------------------------------------------------- logs on disk


@needs_compiled
def test_sample_and_realworld_json_channels_equal_the_ndjson_route():
    channels = 0
    for path in JSON_LOGS:
        scan = scan_mcap(path.read_bytes())
        for cid, messages in scan.messages.items():
            if scan.channels[cid].message_encoding != "json":
                continue
            frame = decode_uniform(messages.payloads)
            assert frame is not None, (path.name, scan.channels[cid].topic)
            expected = decode_json_ndjson(None, scan.channels[cid], messages.payloads).frame
            assert_frame_equal(frame, expected, check_exact=True)
            channels += 1
    assert channels >= 14 * 5  # sample_logs: 14 JSON logs of 5 topics (realworld: CDR only)


# ---------------------------------------------------------------- random uniform channels


class _Num:
    """A number position of the structure: how its values are drawn."""

    def __init__(self, kind: str) -> None:
        self.kind = kind  # int, float, mixed (ints, a float somewhere), nonfinite


class _Raw:
    def __init__(self, text: str) -> None:
        self.text = text


_KEYS = st.text(alphabet='abxyz_0Aé"\\/ \t\n', min_size=1, max_size=5)
_NUM = st.sampled_from(["int", "float", "float", "mixed", "nonfinite"]).map(_Num)
_LEAF = st.one_of(
    _NUM,
    st.text(alphabet=st.characters(codec="utf-8", exclude_categories=["Cs"]), max_size=4),
    st.sampled_from([True, False, None]),
    st.lists(_NUM, min_size=1, max_size=4),
)
_TREE = st.dictionaries(
    _KEYS,
    st.recursive(_LEAF, lambda inner: st.dictionaries(_KEYS, inner, min_size=1, max_size=3)),
    min_size=1,
    max_size=4,
)


def _float(rng: random.Random) -> float:
    pick = rng.randrange(6)
    if pick == 0:
        return struct.unpack("<d", rng.getrandbits(64).to_bytes(8, "little"))[0]
    if pick == 1:
        return rng.uniform(-1e3, 1e3)
    if pick == 2:
        return rng.choice([-0.0, 0.0, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308])
    if pick == 3:
        return float(rng.randint(-(10**6), 10**6))
    return rng.gauss(0.0, 1.0) * 10.0 ** rng.randint(-30, 30)


def _number_text(value: float, rng: random.Random) -> str:
    if isinstance(value, int) or not math.isfinite(value):
        return json.dumps(value)
    return rng.choice([repr(value), f"{value:.17e}", f"{value:.17E}", f"{value:.6g}"])


def _value(num: _Num, row: int, special: int, rng: random.Random) -> Any:
    if num.kind == "int" or (num.kind in ("mixed", "nonfinite") and row != special):
        return rng.choice([rng.randint(-1000, 1000), rng.randint(-(2**63), 2**63 - 1), 0])
    if num.kind == "nonfinite":
        return rng.choice([math.nan, math.inf, -math.inf])
    value = _float(rng)
    return value if math.isfinite(value) else 1.5


def _fill(tree: Any, row: int, specials: dict[int, int], rng: random.Random) -> Any:
    if isinstance(tree, _Num):
        return _Raw(_number_text(_value(tree, row, specials[id(tree)], rng), rng))
    if isinstance(tree, dict):
        return {k: _fill(v, row, specials, rng) for k, v in tree.items()}
    if isinstance(tree, list):
        return [_fill(v, row, specials, rng) for v in tree]
    return tree


def _dump(obj: Any, space: str, ascii: bool) -> str:
    if isinstance(obj, _Raw):
        return obj.text
    if isinstance(obj, dict):
        items = [
            f"{json.dumps(k, ensure_ascii=ascii)}{space}:{space}{_dump(v, space, ascii)}"
            for k, v in obj.items()
        ]
        return "{" + space + f",{space}".join(items) + space + "}"
    if isinstance(obj, list):
        return "[" + ",".join(_dump(v, space, ascii) for v in obj) + "]"
    return json.dumps(obj, ensure_ascii=ascii)


def _numbers(tree: Any) -> list[_Num]:
    if isinstance(tree, _Num):
        return [tree]
    if isinstance(tree, dict):
        return [n for v in tree.values() for n in _numbers(v)]
    if isinstance(tree, list):
        return [n for v in tree for n in _numbers(v)]
    return []


def _channel(tree: dict[str, Any], n: int, seed: int) -> list[bytes]:
    rng = random.Random(seed)
    specials = {id(num): rng.randrange(n) for num in _numbers(tree)}
    spaces = ["", " ", "\n\t "]
    ascii = rng.random() < 0.5  # per channel: the same strings, the same bytes
    return [
        _dump(_fill(tree, row, specials, rng), rng.choice(spaces), ascii).encode()
        for row in range(n)
    ]


def _unique_names(tree: dict[str, Any], prefix: str = "") -> list[str]:
    names: list[str] = []
    for key, value in tree.items():
        name = f"{prefix}.{key}" if prefix else key
        if isinstance(value, dict):
            names += _unique_names(value, name)
        elif isinstance(value, list):
            names += [f"{name}.{i}" for i in range(len(value))]
        else:
            names.append(name)
    return names


@needs_compiled
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tree=_TREE, n=st.sampled_from([1, 3, 40, 1300]), seed=st.integers(0, 2**32))
def test_random_uniform_channels_equal_the_ndjson_route(tree, n, seed):
    names = _unique_names(tree)
    _same_as_route(_channel(tree, n, seed), compiled=len(set(names)) == len(names))


@needs_compiled
def test_int_column_turning_float_after_the_inferred_head():
    # the route infers Int64 from the first 1000 rows, polars raises, the whole is inferred
    msgs = [b'{"a": %d, "b": [1, 2]}' % i for i in range(1200)]
    msgs[1100] = b'{"a": 1.5, "b": [1, 2.5]}'
    _same_as_route(msgs, compiled=True)
    frame = decode_uniform(Payloads.from_bytes(msgs))
    assert frame is not None
    assert frame.schema == pl.Schema({"a": pl.Float64, "b.0": pl.Float64, "b.1": pl.Float64})


@needs_compiled
def test_integer_forms_and_negative_zero():
    msgs = [
        b'{"a": -0, "b": -0, "c": 1E5, "d": 9223372036854775807}',
        b'{"a":1,"b":0.5,"c":2,"d":-9223372036854775808}',
    ]
    _same_as_route(msgs, compiled=True)
    frame = decode_uniform(Payloads.from_bytes(msgs))
    assert frame is not None
    assert frame.dtypes == [pl.Int64, pl.Float64, pl.Float64, pl.Int64]
    assert math.copysign(1.0, frame["b"][0]) == 1.0  # -0 is the integer 0, then 0.0


@needs_compiled
def test_long_arrays_keep_their_first_items_and_one_dtype():
    items = list(range(MAX_ARRAY_ITEMS + 40))
    first = json.dumps({"p": items}).encode()
    items[-1] = 0.25  # beyond the kept columns, yet it makes the whole list Float64
    msgs = [first, json.dumps({"p": items}).encode()]
    _same_as_route(msgs, compiled=True)
    frame = decode_uniform(Payloads.from_bytes(msgs))
    assert frame is not None
    assert frame.width == MAX_ARRAY_ITEMS
    assert set(frame.dtypes) == {pl.Float64}


@needs_compiled
def test_nan_and_infinity_columns_typed_as_the_per_message_route():
    msgs = [b'{"a": [1, 2], "b": 3}', b'{"a": [NaN, 2], "b": -Infinity}', b'{"a": [1, 2], "b": 4}']
    _same_as_route(msgs, compiled=True)
    frame = decode_uniform(Payloads.from_bytes(msgs))
    assert frame is not None
    assert frame.dtypes == [pl.Float64, pl.Int64, pl.Float64]  # polars raised: column by column


# ---------------------------------------------------------------- channels that fall back


def _uniform(n: int = 1200) -> list[bytes]:
    return [json.dumps({"v": i * 0.5, "s": "a", "o": {"w": i}}).encode() for i in range(n)]


@needs_compiled
@pytest.mark.parametrize(
    "change",
    [
        b'{"v": 1.0, "s": "a", "o": {"W": 1}}',  # a key renamed
        b'{"v": "1.0", "s": "a", "o": {"w": 1}}',  # a number turns into a string
        b'{"v": 1.0, "s": "b", "o": {"w": 1}}',  # the constant string varies
        b'{"v": 1.0, "s": "\\u0061", "o": {"w": 1}}',  # the same string, escaped
        b'{"v": 1.0, "s": "a", "o": {"w": 1}, "x": 2}',  # a field more
        b'{"v": 1.0, "s": "a", "o": {"w": 18446744073709551616}}',  # beyond int64
        b'{"v": 1.0, "s": "a", "o": {"w": 1}} x',  # trailing bytes
        b'{"v": 01, "s": "a", "o": {"w": 1}}',  # not a JSON number
    ],
)
def test_a_message_that_differs_sends_the_channel_to_the_ndjson_route(change):
    msgs = _uniform()
    msgs[500] = change
    assert decode_uniform(Payloads.from_bytes(msgs)) is None
    expected = decode_json_ndjson(None, None, msgs)
    got = decode_json(None, None, msgs)
    assert got.kept == expected.kept
    assert_frame_equal(got.frame, expected.frame, check_exact=True)


@needs_compiled
@pytest.mark.parametrize(
    "first",
    [
        b'{"a": 1, "a": 2}',  # a key twice
        b'{"a.b": 1, "a": {"b": 2}}',  # two fields, one flattened name
        b'{"a": []}',
        b'{"a": {}}',
        b'{"a": ["x", 1]}',  # an array not all numbers
        b"[1, 2]",
        b"\xef\xbb\xbf{}",
        b'{"a": "\\ud800"}',  # a lone surrogate
        b'{"a": tru e}',
    ],
)
def test_first_messages_the_walk_does_not_take(first):
    assert decode_uniform(Payloads.from_bytes([first, first])) is None


def test_without_the_extension_every_channel_takes_the_ndjson_route(monkeypatch):
    msgs = _uniform(50)
    expected = _route(msgs)
    monkeypatch.setattr(flat_json, "_library", lambda: None)
    assert not compiled_available()
    assert decode_uniform(Payloads.from_bytes(msgs)) is None
    assert_frame_equal(decode_json(None, None, msgs).frame, expected, check_exact=True)


# ---------------------------------------------------------------- the number parser


def _bits(value: float) -> bytes:
    return struct.pack("<d", value)


def _check_number(text: str) -> None:
    got = parse_number(text.encode())
    expected = json.loads(text)
    if isinstance(expected, int):
        assert isinstance(got, int) == (-(2**63) <= expected < 2**63), text
        if isinstance(got, int):
            assert got == expected
        return
    assert isinstance(got, float), text
    assert _bits(got) == _bits(float(text)) or (math.isnan(got) and math.isnan(float(text)))


EDGES = [
    "0", "-0", "0.0", "-0.0", "1e22", "1e23", "-1e23", "5e-324", "4.9e-324",
    "2.4703282292062327e-324", "2.4703282292062328e-324", "2.2250738585072011e-308",
    "2.2250738585072014e-308",
    "1.7976931348623157e308", "1.7976931348623158e308", "1.7976931348623159e308", "1e400",
    "-1e400", "1e-400", "9007199254740993", "9007199254740993.0", "9007199254740992.5",
    "9007199254740993.5", "0.1", "0.3", "1.0000000000000002", "1.00000000000000011102230246251565",
    "1.00000000000000011102230246251566", "1.00000000000000011102230246251564",
    "123456789012345678", "1234567890123456789", "12345678901234567890",
    "9223372036854775807", "9223372036854775808", "-9223372036854775808",
    "-9223372036854775809", "0.000000000000000000000000000001", "1E5", "1e+5", "1E-5",
    "3.14159265358979323846264338327950288", "NaN", "Infinity", "-Infinity",
    "8.98846567431158e307", "1e-7", "1.8014398509481984e16", "4.35679845e-320",
]  # fmt: skip


@needs_compiled
@pytest.mark.parametrize("text", EDGES)
def test_number_edge_cases_match_float(text):
    _check_number(text)


@needs_compiled
@settings(max_examples=400, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False))
def test_repr_of_any_double_parses_to_it(value):
    _check_number(repr(value))
    _check_number(f"{value:.17e}")
    _check_number(f"{value:.20e}")


@needs_compiled
@settings(max_examples=400, deadline=None)
@given(
    whole=st.text(alphabet="0123456789", min_size=1, max_size=20),
    frac=st.text(alphabet="0123456789", max_size=25),
    exponent=st.one_of(st.none(), st.integers(-340, 330)),
    negative=st.booleans(),
)
def test_random_digit_strings_parse_as_float_does(whole, frac, exponent, negative):
    text = ("-" if negative else "") + (whole.lstrip("0") or "0") + (f".{frac}" if frac else "")
    _check_number(text + (f"e{exponent}" if exponent is not None else ""))


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(mantissa=st.integers(2**52, 2**53 - 1), shift=st.integers(-1074, 970))
def test_near_halfway_points_parse_as_float_does(mantissa, shift):
    # the point halfway between the doubles m 2^shift and (m + 1) 2^shift, written exactly and
    # cut to 17-20 significant digits (below and above it): the cases the fast path must not
    # round the wrong way
    with decimal.localcontext() as ctx:
        ctx.prec = 1200
        mid = decimal.Decimal(2 * mantissa + 1) * decimal.Decimal(2) ** (shift - 1)
        _check_number(f"{mid:e}")
        for digits in (17, 18, 19, 20):
            for rounding in (decimal.ROUND_DOWN, decimal.ROUND_UP):
                ctx.prec, ctx.rounding = digits, rounding
                _check_number(f"{+mid:e}")
                ctx.prec = 1200


@needs_compiled
@pytest.mark.parametrize(
    "text",
    ["01", "1.", ".5", "+1", "1e", "1e+", "-", "--1", "-NaN", "nan", "inf", "1.5 ", " 1", "0x1"],
)
def test_text_that_is_not_a_json_number(text):
    assert parse_number(text.encode()) is None
