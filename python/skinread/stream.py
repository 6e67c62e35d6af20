"""Records from the record link: a recorded stream (`stream.bin`), a TCP
socket, a serial port. A stream is taken as `live` takes it
(docs/data-format.md, "The record link"): each start frame begins a
segment; within one, a frame numbered at or before the highest taken is
a duplicate, dropped; a record of a sensor beyond the start frame's count,
or not later than its sensor's last, is set aside.
"""

from __future__ import annotations

import os
import socket
from dataclasses import dataclass, field
from typing import Dict, Iterable, Iterator, List, Optional, Tuple

import numpy as np
import pandas as pd

from . import flags as _flags
from .wire import VERSION, Applied, Decoder, End, Frame, Record, Start, Status

#: The columns of a records frame: `live`'s records.csv, with the flags'
#: bits as `flag_bits` (a column `flags` would shadow DataFrame.flags),
#: C in pF and the host's UTC at arrival in µs (NaN where not known).
COLUMNS = [
    "segment", "seq", "t_us", "sensor",
    "f1_hz", "z1_re_ohm", "z1_im_ohm", "f2_hz", "z2_re_ohm", "z2_im_ohm",
    "c_pf", "r_ohm", "stretch_mm", "chosen_hz", "chi2", "sigma_ln_c", "flag_bits",
    "host_utc_us",
]


@dataclass
class Taken:
    """What a stream gave: the records kept, and the counts of the rest."""

    rows: List[tuple] = field(default_factory=list)
    starts: List[Start] = field(default_factory=list)
    ends: List[End] = field(default_factory=list)
    statuses: List[Status] = field(default_factory=list)
    #: Each segment's sets in force: [(sequence number after which it
    #: holds, generation)], the start frame's first.
    in_force: Dict[int, List[Tuple[int, int]]] = field(default_factory=dict)
    duplicates: int = 0
    set_aside: int = 0
    stray: int = 0
    stopped: Optional[str] = None


class Taker:
    """Frames taken in as `live` takes them."""

    def __init__(self) -> None:
        self.taken = Taken()
        self._high: Optional[int] = None
        self._ended = False
        self._last_t: Dict[int, int] = {}

    def take(self, frame: Frame, host_utc_us: Optional[int] = None) -> Optional[tuple]:
        """Take `frame`, arrived at `host_utc_us` where known; the row of
        a record kept, else None."""
        t, body = self.taken, frame.body
        if t.stopped:
            return None
        if isinstance(body, Start):
            if body.version != VERSION:
                t.stopped = "wire version %d, this reader knows %d" % (body.version, VERSION)
                if not t.starts:
                    raise ValueError(t.stopped)
                return None
            t.starts.append(body)
            t.in_force[len(t.starts)] = [(frame.seq, body.generation)]
            self._high, self._ended, self._last_t = frame.seq, False, {}
            return None
        if self._high is None:
            t.stray += 1
            return None
        ahead = (frame.seq - self._high) & 0xFFFFFFFF
        if ahead == 0 or ahead > 0xFFFFFFFF // 2:
            t.duplicates += 1
            return None
        self._high = frame.seq
        if self._ended:
            t.stray += 1
        elif isinstance(body, Record):
            return self._record(frame.seq, body, host_utc_us)
        elif isinstance(body, End):
            t.ends.append(body)
            self._ended = True
        elif isinstance(body, Status):
            t.statuses.append(body)
        elif isinstance(body, Applied):
            t.in_force[len(t.starts)].append((frame.seq, body.generation))
        else:
            t.stray += 1
        return None

    def _record(self, seq: int, r: Record, host_utc_us: Optional[int]) -> Optional[tuple]:
        t = self.taken
        last = self._last_t.get(r.sensor)
        if r.sensor >= t.starts[-1].sensors or (last is not None and r.t_us <= last):
            t.set_aside += 1
            return None
        self._last_t[r.sensor] = r.t_us
        a, b = r.tones
        row = (
            len(t.starts), seq, r.t_us, r.sensor,
            a.f_hz, a.z_re_ohm, a.z_im_ohm, b.f_hz, b.z_re_ohm, b.z_im_ohm,
            np.float64(np.float32(r.c_farad)) * 1e12, r.r_ohm, r.stretch_mm,
            r.chosen_hz, r.chi2, r.sigma_ln_c, r.flags,
            np.nan if host_utc_us is None else host_utc_us,
        )
        t.rows.append(row)
        return row


def frame(rows: Iterable[tuple]) -> pd.DataFrame:
    """Rows taken into a frame with the flags decoded by name: `valid`
    (no fault bit) and a boolean column per flag."""
    df = pd.DataFrame(list(rows), columns=COLUMNS)
    for c in ("segment", "seq", "t_us", "sensor", "flag_bits"):
        df[c] = df[c].astype("int64")
    return with_flag_names(df)


def with_generation(df: pd.DataFrame, in_force: Dict[int, List[Tuple[int, int]]]) -> pd.DataFrame:
    """`generation`: the stored set each record was measured with, from
    its segment's sets in force ([(sequence number after which it holds,
    generation)]; 0: none stored, -1: a segment without them)."""
    gen = np.full(len(df), -1, dtype=np.int64)
    seg, seq = df["segment"].to_numpy(), df["seq"].to_numpy()
    for g, changes in in_force.items():
        for from_seq, generation in sorted(changes):
            gen[(seg == g) & (seq > from_seq)] = generation
    df["generation"] = gen
    return df


def with_flag_names(df: pd.DataFrame) -> pd.DataFrame:
    """`valid` and one boolean column per flag, from `flag_bits`."""
    bits = df["flag_bits"].fillna(0).to_numpy(dtype=np.int64)
    df["valid"] = (bits & _flags.FAULTS) == 0
    for bit, name in _flags.FLAGS:
        df[name] = (bits >> bit & 1).astype(bool)
    return df


def read_arrivals(path: str) -> List[Tuple[int, int]]:
    """A session's `arrivals.csv`: (the stream's length in bytes at the
    end of a read that completed records, the host's UTC then in µs)."""
    df = pd.read_csv(path, dtype="int64")
    if list(df.columns) != ["stream_bytes", "host_utc_us"]:
        raise ValueError("%s:1:1: the header must be 'stream_bytes,host_utc_us'" % path)
    return list(zip(df["stream_bytes"].tolist(), df["host_utc_us"].tolist()))


def read_stream(path: str, arrivals: Optional[str] = "beside") -> Tuple[pd.DataFrame, Taken]:
    """Every record of a recorded stream (`stream.bin`), as `live` keeps
    them, and what else the stream held. Each record's `host_utc_us` is
    the end of the read that brought it, from `arrivals` (a session's
    `arrivals.csv`; "beside": the one next to `path`, where there is
    one; None: not read)."""
    if arrivals == "beside":
        near = os.path.join(os.path.dirname(path), "arrivals.csv")
        arrivals = near if os.path.exists(near) else None
    ends = read_arrivals(arrivals) if arrivals else []
    taker = Taker()
    dec = Decoder()
    at, k = 0, 0
    with open(path, "rb") as f:
        while True:
            # Up to the next read's end, so that its frames get its time.
            want = ends[k][0] - at if k < len(ends) else 1 << 16
            chunk = f.read(max(1, min(want, 1 << 16)))
            if not chunk:
                break
            at += len(chunk)
            time = ends[k][1] if k < len(ends) else None
            for fr in dec.feed(chunk):
                taker.take(fr, time)
            if k < len(ends) and at >= ends[k][0]:
                k += 1
    return with_generation(frame(taker.taken.rows), taker.taken.in_force), taker.taken


def tcp_frames(host: str, port: int, timeout: Optional[float] = None) -> Iterator[Frame]:
    """Frames from a TCP stream (QEMU's UART on a socket, a bridge), as
    they arrive, until the peer closes it."""
    dec = Decoder()
    with socket.create_connection((host, port), timeout=timeout) as s:
        while True:
            chunk = s.recv(4096)
            if not chunk:
                return
            yield from dec.feed(chunk)


def serial_frames(port: str, baud: int = 15_000_000) -> Iterator[Frame]:
    """Frames from a serial port (the board's ST-LINK virtual COM port);
    needs pyserial (`pip install ./python[serial]`)."""
    import serial  # type: ignore

    dec = Decoder()
    with serial.Serial(port, baud, timeout=0.2) as s:
        while True:
            yield from dec.feed(s.read(4096))


def records(frames: Iterable[Frame]) -> Iterator[tuple]:
    """The rows of the records kept, as frames arrive (a live source)."""
    taker = Taker()
    for fr in frames:
        row = taker.take(fr)
        if row is not None:
            yield row
