"""Read a DE sensing skin's data into Python: data sets into pandas, the
record link frame by frame (docs/data-format.md)."""

from .dataset import (boards, by_sensor, clocks, read_dataset, read_markers, read_records, read_skin,
                      read_traces, skin)
from . import feed
from .flags import FLAGS, names, valid
from .stream import COLUMNS, read_arrivals, read_stream, records, serial_frames, tcp_frames
from .wire import Decoder, Frame, FrameError, Record, Start, decode

__all__ = [
    "feed", "boards", "by_sensor", "clocks", "skin", "read_dataset", "read_markers", "read_records", "read_skin",
    "read_traces",
    "FLAGS", "names", "valid",
    "COLUMNS", "read_arrivals", "read_stream", "records", "serial_frames", "tcp_frames",
    "Decoder", "Frame", "FrameError", "Record", "Start", "decode",
]
