"""The LSL bridge's logic with a stand-in for pylsl (the real one is
tested against `live` in live/tests/lsl.rs): a sample per time stamp, a
block split over two batches kept whole, and after a gap the backlog
taken again without pushing a sample twice."""

import json

from skinread import lsl

FIELDS = ["t_s", "sensor", "c_pf", "r_ohm", "stretch_mm", "chosen_hz", "flag_bits", "segment", "seq", "host_utc_s"]
FLAGS = {"version": 2, "fields": [{"name": n, "unit": ""} for n in FIELDS],
         "flags": [{"bit": 6, "name": "DISTURBED", "fault": True}]}
DEVICE = {"segment": 1, "sensors": 2, "firmware": "t", "names": ["thumb", None],
          "clock": {"offset_unix_s": 1.8e9, "rate": 1.0}}


class Node:
    def __init__(self):
        self.children = []

    def append_child(self, name):
        n = Node()
        self.children.append((name, n))
        return n

    def append_child_value(self, name, value):
        self.children.append((name, value))


class Info:
    def __init__(self, name, kind, count, rate, fmt, source):
        self.name, self.kind, self.count, self._desc = name, kind, count, Node()

    def desc(self):
        return self._desc


class Outlet:
    def __init__(self, info):
        self.info, self.pushed = info, []

    def push_sample(self, x, ts):
        self.pushed.append((list(x), ts))


class FakeLsl:
    IRREGULAR_RATE, cf_double64, cf_string = 0.0, 1, 2
    StreamInfo, StreamOutlet = Info, Outlet

    @staticmethod
    def local_clock():
        return 100.0


def row(k, sensor, segment=1):
    t = 0.002 + 0.004 * k
    return [t, sensor, 200.0 + k, 7e5, k / 10, 1000.0, 0, segment, 2 * k + sensor + 1, 1.8e9 + t]


def test_a_block_split_over_batches_is_one_sample_and_a_backlog_is_not_pushed_twice():
    b = lsl.Bridge(FakeLsl, "skin", ["c_pf", "flag_bits"], "src")
    b.schema = FLAGS
    b.device(DEVICE)
    out = b.outlet
    assert out.info.count == 4
    # Block 0 whole, block 1 split between two batches.
    b.batch([row(0, 0), row(0, 1), row(1, 0)], FIELDS)
    b.batch([row(1, 1), row(2, 0)], FIELDS)
    assert [s[0][0] for s in out.pushed] == [200.0, 201.0]
    assert out.pushed[1][0][2] == 201.0, "sensor 1 of block 1 joined its block"
    # A gap: the feed again from its backlog, blocks 0 to 3.
    b.held = []
    b.batch([row(k, s) for k in range(4) for s in (0, 1)], FIELDS, last=True)
    assert [s[0][0] for s in out.pushed] == [200.0, 201.0, 202.0, 203.0]
    # Channels labelled by the skin's names.
    labels = [c for name, c in out.info.desc().children if name == "channels"][0]
    first = [v for n, v in labels.children[0][1].children if n == "label"][0]
    assert first == "thumb.c_pf"


def test_the_bridge_connects_again_after_a_gap(monkeypatch):
    # The first connection falls behind after block 1; the second gives
    # the backlog from block 0 and the rest, then the end.
    first = [("schema", json.dumps(FLAGS)), ("device", json.dumps(DEVICE)),
             ("message", json.dumps([row(0, 0), row(0, 1)])), ("message", json.dumps([row(1, 0)])),
             ("gap", "5")]
    second = [("schema", json.dumps(FLAGS)), ("device", json.dumps(DEVICE)),
              ("message", json.dumps([row(k, s) for k in range(3) for s in (0, 1)])), ("end", "end")]
    feeds = iter([first, second])
    monkeypatch.setattr(lsl.feed, "events", lambda url, timeout=None: iter(next(feeds)))
    pushed = []
    monkeypatch.setattr(Outlet, "push_sample", lambda self, x, ts: pushed.append(list(x)))
    monkeypatch.setattr(lsl.time, "sleep", lambda s: None)
    import sys
    monkeypatch.setitem(sys.modules, "pylsl", FakeLsl)
    assert lsl.run("http://x", "skin", ["c_pf"], linger=0) == 0
    data = [p for p in pushed if isinstance(p[0], float)]
    assert [p[0] for p in data] == [200.0, 201.0, 202.0]
