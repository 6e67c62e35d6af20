"""The wire decoder against the spec's parts: COBS, CRC-32/ISO-HDLC,
postcard; a frame built here byte by byte from docs/data-format.md."""

import random
import struct

import pytest

from skinread import wire


def cobs_encode(data: bytes) -> bytes:
    """The reference COBS encoding (Cheshire and Baker, 1999)."""
    out, block = bytearray(), bytearray()
    for b in data:
        if b == 0:
            out += bytes([len(block) + 1]) + block
            block = bytearray()
        else:
            block.append(b)
            if len(block) == 254:
                out += bytes([255]) + block
                block = bytearray()
    out += bytes([len(block) + 1]) + block
    return bytes(out)


def varint(v: int) -> bytes:
    out = bytearray()
    while True:
        b = v & 0x7F
        v >>= 7
        if v:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def sealed(body: bytes) -> bytes:
    return cobs_encode(body + struct.pack("<I", wire.crc32(body)))


def test_cobs_decodes_the_papers_examples_and_random_data():
    assert wire.cobs_decode(bytes([0x01, 0x01])) == b"\0"
    assert wire.cobs_decode(bytes([0x03, 0x11, 0x22, 0x02, 0x33])) == bytes([0x11, 0x22, 0x00, 0x33])
    rng = random.Random(26)
    for n in range(0, 300):
        data = bytes(rng.choice([0, rng.randrange(1, 256)]) for _ in range(n))
        assert wire.cobs_decode(cobs_encode(data)) == data
    with pytest.raises(wire.FrameError):
        wire.cobs_decode(bytes([0x05, 0x11]))


def test_crc_is_iso_hdlc():
    # The catalogue's check value of CRC-32/ISO-HDLC.
    assert wire.crc32(b"123456789") == 0xCBF43926


#: A start frame's self-test that did not run: its seven fields zero.
NOT_RUN = bytes(7)


def record_body(seq=7, t_us=1_234_567, sensor=3, flags=256):
    f = lambda *xs: struct.pack("<%df" % len(xs), *xs)
    return (
        varint(seq) + varint(1) + varint(t_us) + bytes([sensor])
        + f(1000.0, 120e3, -776e3, 4000.0, 110e3, -194e3)
        + f(205e-12, 7.1e5, 12.5, 4000.0, 3.9, 4e-4) + varint(flags)
    )


def test_a_record_built_from_the_spec_decodes_field_by_field():
    fr = wire.decode(sealed(record_body()))
    assert fr.seq == 7
    r = fr.body
    assert isinstance(r, wire.Record)
    assert (r.t_us, r.sensor, r.flags) == (1_234_567, 3, 256)
    assert r.tones[1].f_hz == 4000.0
    assert r.c_farad == struct.unpack("<f", struct.pack("<f", 205e-12))[0]


def test_start_end_and_status_frames():
    zigzag = lambda v: varint(((v << 1) ^ (v >> 31)) & 0xFFFFFFFF)
    # Its self-test: Failed (2), sensor 5's path (bit 6), the
    # excitation noisy, +120 ppm, -4500 µrad, -3 ppm, 1.021x.
    test = varint(2) + varint(1 << 6) + varint(1) + zigzag(120) + zigzag(-4500) + zigzag(-3) + varint(1021)
    start = varint(0) + varint(0) + varint(5) + b"skin-array 0.1.0".ljust(24, b"\0") \
        + varint(0xDEADBEEF) + varint(0x0BADF00D) + bytes([16]) + varint(25_000) + varint(7) + varint(0xA1B2C3D4) \
        + test
    s = wire.decode(sealed(start)).body
    assert (s.version, s.firmware, s.sensors, s.sample_rate_hz) == (5, "skin-array 0.1.0", 16, 25_000)
    assert s.settings_digest == 0xDEADBEEF and s.generation == 7 and s.device_id == 0xA1B2C3D4
    assert s.self_test == wire.SelfTest("Failed", 1 << 6, 1, 120, -4500, -3, 1021)
    end = wire.decode(sealed(varint(9) + varint(2) + varint(1000) + varint(0))).body
    assert (end.records, end.dropped) == (1000, 0)
    status = varint(5) + varint(5) + varint(10**6) + varint(1) + b"".join(varint(v) for v in range(7))
    st = wire.decode(sealed(status)).body
    assert st.clock == "Instructions" and st.missed == 6


def test_a_corrupted_or_padded_frame_is_refused_and_the_stream_goes_on():
    good = sealed(record_body())
    bad = bytearray(good)
    bad[5] ^= 0x10
    with pytest.raises(wire.FrameError, match="CRC"):
        wire.decode(bytes(bad))
    with pytest.raises(wire.FrameError, match="left over"):
        wire.decode(sealed(record_body() + b"\x00"))
    d = wire.Decoder()
    got = list(d.feed(bytes(bad) + b"\0" + good + b"\0"))
    assert len(got) == 1 and got[0].body.sensor == 3
    assert len(d.refused) == 1


def test_check_finds_a_records_file_that_is_not_its_stream(tmp_path):
    from skinread import check

    start = varint(0) + varint(0) + varint(5) + b"t".ljust(24, b"\0") + varint(1) + varint(2) + bytes([4]) \
        + varint(25_000) + varint(0) + varint(0) + NOT_RUN
    stream = sealed(start) + b"\0" + sealed(record_body(seq=1)) + b"\0"
    # A duplicate (seq 1 again) is dropped, as live drops it.
    stream += sealed(record_body(seq=1)) + b"\0"
    (tmp_path / "stream.bin").write_bytes(stream)
    head = "segment,seq,t_us,sensor,f1_hz,z1_re_ohm,z1_im_ohm,f2_hz,z2_re_ohm,z2_im_ohm,c_pf,r_ohm,stretch_mm,chosen_hz,chi2,sigma_ln_c,flags,host_utc_us\n"
    row = "1,1,1234567,3,1000,120000,-776000,4000,110000,-194000,205.0000,710000,12.5,4000,3.9,0.0004,256,\n"
    (tmp_path / "records.csv").write_text(head + row)
    assert check.agree(str(tmp_path)) == 1
    (tmp_path / "records.csv").write_text(head + row.replace(",12.5,", ",12.6,"))
    with pytest.raises(AssertionError, match="stretch_mm"):
        check.agree(str(tmp_path))
    # With the session's arrivals, the record's host time is the end of
    # the read that completed it.
    at = len(sealed(start) + b"\0" + sealed(record_body(seq=1)) + b"\0")
    (tmp_path / "arrivals.csv").write_text("stream_bytes,host_utc_us\n%d,1796292001003000\n" % at)
    (tmp_path / "records.csv").write_text(head + row.replace(",256,", ",256,1796292001003000"))
    assert check.agree(str(tmp_path)) == 1
    (tmp_path / "records.csv").write_text(head + row.replace(",256,", ",256,1796292001003001"))
    with pytest.raises(AssertionError, match="host_utc_us"):
        check.agree(str(tmp_path))


def test_records_after_an_applied_frame_are_of_its_generation(tmp_path):
    from skinread.stream import read_stream

    start = varint(0) + varint(0) + varint(5) + b"t".ljust(24, b"\0") + varint(1) + varint(2) + bytes([4]) \
        + varint(25_000) + varint(2) + varint(0) + NOT_RUN
    applied = varint(2) + varint(6) + varint(3) + varint(0xAB) + varint(0xCD) + varint(1234567)
    a = wire.decode(sealed(applied)).body
    assert a == wire.Applied(3, 0xAB, 0xCD, 1234567)
    later = record_body(seq=3, t_us=1_238_567)
    stream = b"".join(sealed(f) + b"\0" for f in (start, record_body(seq=1), applied, later))
    (tmp_path / "stream.bin").write_bytes(stream)
    df, taken = read_stream(str(tmp_path / "stream.bin"))
    assert taken.in_force == {1: [(0, 2), (2, 3)]}
    assert df["generation"].tolist() == [2, 3]
