"""The record link's frames, as docs/data-format.md ("The record link")
specifies them: postcard bytes (varint integers, f32 little-endian),
their CRC-32/ISO-HDLC little-endian, the whole COBS-encoded and closed by
a zero byte. Written from the spec alone: a second implementation of
the wire format beside the `link` crate.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field
from typing import Iterable, Iterator, List, Optional, Tuple, Union

#: The wire format's version this reader knows.
VERSION = 5
#: The longest frame on the wire, its closing zero excluded (bytes).
MAX_FRAME = 96


class FrameError(ValueError):
    """A frame that cannot be the device's: corrupted, too long, unknown."""


def cobs_decode(data: bytes) -> bytes:
    """COBS-decode one frame (without its closing zero)."""
    out = bytearray()
    i, n = 0, len(data)
    while i < n:
        code = data[i]
        if code == 0:
            raise FrameError("not a COBS frame: a zero inside it")
        end = i + code
        if end > n:
            raise FrameError("not a COBS frame: a block runs past its end")
        block = data[i + 1 : end]
        if 0 in block:
            raise FrameError("not a COBS frame: a zero inside it")
        out += block
        i = end
        if code < 0xFF and i < n:
            out.append(0)
    return bytes(out)


def crc32(data: bytes) -> int:
    """CRC-32/ISO-HDLC (zlib's)."""
    return zlib.crc32(data) & 0xFFFFFFFF


class _Reader:
    """postcard's reading of a struct's fields, in order."""

    def __init__(self, data: bytes):
        self.data, self.i = data, 0

    def _take(self, n: int) -> bytes:
        if self.i + n > len(self.data):
            raise FrameError("an unknown frame type or layout: too short")
        b = self.data[self.i : self.i + n]
        self.i += n
        return b

    def u8(self) -> int:
        return self._take(1)[0]

    def varint(self, bits: int) -> int:
        """An unsigned integer of `bits` bits, LEB128."""
        value, shift = 0, 0
        for _ in range((bits + 6) // 7):
            b = self.u8()
            value |= (b & 0x7F) << shift
            if b < 0x80:
                if value >= 1 << bits:
                    raise FrameError("an unknown frame type or layout: an integer too large")
                return value
            shift += 7
        raise FrameError("an unknown frame type or layout: an integer too long")

    def u16(self) -> int:
        return self.varint(16)

    def u32(self) -> int:
        return self.varint(32)

    def u64(self) -> int:
        return self.varint(64)

    def i32(self) -> int:
        """A signed integer, zigzag then LEB128 (postcard's)."""
        z = self.varint(32)
        return (z >> 1) ^ -(z & 1)

    def f32(self) -> float:
        return struct.unpack("<f", self._take(4))[0]

    def raw(self, n: int) -> bytes:
        return self._take(n)

    def variant(self, names: Tuple[str, ...]) -> str:
        k = self.u32()
        if k >= len(names):
            raise FrameError("an unknown frame type or layout: variant %d" % k)
        return names[k]

    def end(self) -> None:
        if self.i != len(self.data):
            raise FrameError("an unknown frame type or layout: bytes left over")


@dataclass(frozen=True)
class Tone:
    """One tone measured: its frequency (Hz) and the impedance (Ω)."""

    f_hz: float
    z_re_ohm: float
    z_im_ohm: float


@dataclass(frozen=True)
class SelfTest:
    """The power-up self-test (docs/data-format.md): a path is an ADC
    input, bit 0 the excitation, 1-16 the sensors' stages, 17 the
    reference network's."""

    #: "NotRun", "Passed" or "Failed".
    verdict: str
    #: Paths that failed a check: their sensors' records are flagged
    #: SELF_TEST (every sensor's if bit 0 or 17 is set).
    failed: int
    #: Paths whose noise exceeded its bound (reported only).
    noisy: int
    #: The reference's worst |Z| error, ppm, and phase error, µrad.
    gain_ppm: int
    phase_urad: int
    #: The excitation's worst tone amplitude error, ppm.
    excitation_ppm: int
    #: The noisiest path's residual over the converter's noise, ‰.
    noise_permille: int


@dataclass(frozen=True)
class Start:
    version: int
    firmware: str
    settings_digest: int
    calibration_digest: int
    sensors: int
    sample_rate_hz: int
    #: The stored set's generation in force at the start (0: none stored).
    generation: int
    #: The device's id (a board's: the CRC-32 of its chip's unique ID).
    device_id: int
    #: What the power-up self-test found.
    self_test: SelfTest


@dataclass(frozen=True)
class Record:
    """A record: its fields as the spec lists them (C in farads)."""

    t_us: int
    sensor: int
    tones: Tuple[Tone, Tone]
    c_farad: float
    r_ohm: float
    stretch_mm: float
    chosen_hz: float
    chi2: float
    sigma_ln_c: float
    flags: int


@dataclass(frozen=True)
class End:
    records: int
    dropped: int


@dataclass(frozen=True)
class Status:
    t_us: int
    clock: str
    clock_hz: int
    period: int
    blocks: int
    mean: int
    max: int
    late: int
    missed: int


@dataclass(frozen=True)
class Request:
    kind: str
    fields: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Reply:
    kind: str
    to: int
    fields: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Applied:
    """A new set in force: every record after this frame was measured
    with it, every record before with the one before."""

    generation: int
    settings_digest: int
    calibration_digest: int
    #: A device time between the two sets' records, µs.
    t_us: int


Body = Union[Start, Record, End, Request, Reply, Status, Applied]


@dataclass(frozen=True)
class Frame:
    seq: int
    body: Body


def _chunk(r: _Reader) -> dict:
    return {"offset": r.u16(), "len": r.u8(), "bytes": r.raw(32)}


_REASONS = ("OutOfOrder", "TooLong", "Mismatch", "Malformed", "Setting", "Flash",
            "NothingStored", "OutOfRange", "Unsupported")


def _body(r: _Reader) -> Body:
    kind = r.variant(("Start", "Record", "End", "Request", "Reply", "Status", "Applied"))
    if kind == "Start":
        version, firmware = r.u16(), r.raw(24)
        name = firmware.split(b"\0", 1)[0].decode("ascii", "replace")
        fields = (r.u32(), r.u32(), r.u8(), r.u32(), r.u32(), r.u32())
        test = SelfTest(r.variant(("NotRun", "Passed", "Failed")), r.u32(), r.u32(),
                        r.i32(), r.i32(), r.i32(), r.u16())
        return Start(version, name, *fields, test)
    if kind == "Applied":
        return Applied(r.u32(), r.u32(), r.u32(), r.u64())
    if kind == "Record":
        t_us, sensor = r.u64(), r.u8()
        tones = tuple(Tone(r.f32(), r.f32(), r.f32()) for _ in range(2))
        return Record(t_us, sensor, tones, r.f32(), r.f32(), r.f32(), r.f32(), r.f32(), r.f32(), r.u16())
    if kind == "End":
        return End(r.u32(), r.u32())
    if kind == "Status":
        t_us = r.u64()
        clock = r.variant(("Cycles", "Instructions"))
        return Status(t_us, clock, *(r.u32() for _ in range(7)))
    if kind == "Request":
        req = r.variant(("ReadSettings", "WriteChunk", "Commit", "Start", "Stop", "Sweep"))
        if req == "WriteChunk":
            return Request(req, _chunk(r))
        if req == "Commit":
            return Request(req, {"len": r.u16(), "crc": r.u32()})
        if req == "Sweep":
            return Request(req, {"blocks_per_pair": r.u16()})
        return Request(req)
    rep = r.variant(("Ack", "Refused", "Chunk"))
    to = r.u32()
    if rep == "Ack":
        return Reply(rep, to, {"generation": r.u32()})
    if rep == "Refused":
        reason = r.variant(_REASONS)
        fields = {"reason": reason}
        if reason == "Setting":
            fields.update(sensor=r.u8(), rule=r.u8())
        return Reply(rep, to, fields)
    return Reply(rep, to, _chunk(r))


def decode(cobs_bytes: bytes) -> Frame:
    """One frame from its COBS bytes (the closing zero excluded)."""
    if len(cobs_bytes) > MAX_FRAME:
        raise FrameError("more bytes than a frame can have before its end")
    raw = cobs_decode(cobs_bytes)
    if len(raw) < 5:
        raise FrameError("too short to be a frame")
    body, crc = raw[:-4], int.from_bytes(raw[-4:], "little")
    if crc32(body) != crc:
        raise FrameError("the CRC does not match: the frame was corrupted")
    r = _Reader(body)
    seq = r.u32()
    frame = Frame(seq, _body(r))
    r.end()
    return frame


class Decoder:
    """Frames from a byte stream fed in pieces; a refused frame is
    counted (`refused`), never raised: a stream goes on after it."""

    def __init__(self) -> None:
        self._buf = bytearray()
        self.frames = 0
        self.refused: List[Tuple[int, str]] = []
        self.bytes = 0

    def feed(self, data: bytes) -> Iterator[Frame]:
        for b in data:
            self.bytes += 1
            if b != 0:
                self._buf.append(b)
                continue
            chunk, self._buf = bytes(self._buf), bytearray()
            if not chunk:
                continue
            try:
                frame = decode(chunk)
            except FrameError as e:
                self.refused.append((self.bytes - 1, str(e)))
                continue
            self.frames += 1
            yield frame


def frames(chunks: Iterable[bytes], decoder: Optional[Decoder] = None) -> Iterator[Frame]:
    """Every frame of a stream given in chunks of bytes."""
    d = decoder or Decoder()
    for c in chunks:
        yield from d.feed(c)
