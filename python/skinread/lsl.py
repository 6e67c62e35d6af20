"""A Lab Streaming Layer outlet of a running skin: `live --serve`'s feed
(docs/live.md, "The live feed") in, LSL streams out, so that LabRecorder
or any LSL inlet records the skin beside a camera, a load cell or a
tensile stage on one clock.

    python -m skinread.lsl http://127.0.0.1:8080/ [--name "DE skin"]

One outlet per skin (type `DESkin`, irregular rate, double64): one channel
per sensor and quantity (`s3.c_pf`, `s3.r_ohm`, `s3.stretch_mm`,
`s3.flag_bits` by default; the sensor's name in place of `s3` where
`live --skin` names it, e.g. `index-1.c_pf`), a sample per device time stamp holding every
sensor measured then (NaN for the others). Its time stamps are the
records' own: the device's time mapped to the host's UTC by `live`'s
clock fit (the feed's `device` event; the arrival time before the fit
has two reads), then to LSL's clock. The stream's description names each
channel's sensor, quantity and unit, every flag bit and whether it is a
fault, the firmware and the clock fit at the outlet's start. A second
outlet (type `Markers`, one string channel) carries the session's
markers at their time. With `--markers-from NAME`, the markers of another
LSL stream of that name (a stimulus program's) are written into the
session as markers (`source` `lsl`), at their own time.

Needs `pylsl` (`pip install ./python[lsl]`; its wheels bundle liblsl).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import threading
import time
import urllib.request
from typing import Dict, List, Optional, Sequence, Tuple

from . import feed

#: The quantities a channel can carry, with their units and LSL types.
QUANTITIES: Dict[str, Tuple[str, str]] = {
    "c_pf": ("pF", "Capacitance"),
    "r_ohm": ("ohm", "Resistance"),
    "stretch_mm": ("mm", "Stretch"),
    "flag_bits": ("", "Flags"),
    "chosen_hz": ("Hz", "Frequency"),
    "sigma_ln_c": ("", "Uncertainty"),
    "chi2": ("", "Misfit"),
}
DEFAULT = ("c_pf", "r_ohm", "stretch_mm", "flag_bits")


def sensor_labels(device: dict) -> List[str]:
    """Each input's label: its name in the skin (`live --skin`), else
    `s` and its index."""
    names = device.get("names") or []
    return [names[s] if s < len(names) and names[s] else "s%d" % s for s in range(int(device["sensors"]))]


def channel_labels(sensors: Sequence[str], quantities: Sequence[str]) -> List[str]:
    """The outlet's channels in order: every quantity of the first
    sensor, then the next, …"""
    return ["%s.%s" % (s, q) for s in sensors for q in quantities]


class Clock:
    """Device time → host UTC (the feed's fit), host UTC → LSL's clock."""

    def __init__(self, pylsl) -> None:
        self.pylsl = pylsl
        self.fit: Optional[dict] = None
        self.segment: Optional[int] = None
        # Before the fit: the first record's arrival less its time.
        self.first: Optional[float] = None

    def lsl_minus_utc(self) -> float:
        return self.pylsl.local_clock() - time.time()

    def utc_of(self, t_s: float, arrived: Optional[float]) -> Optional[float]:
        """The host's UTC of device time `t_s` by the fit, else by the
        first record's arrival (rate 1): the records' own spacing kept
        either way, never their arrivals' bunching."""
        if self.fit:
            return self.fit["offset_unix_s"] + self.fit["rate"] * t_s
        if self.first is None and arrived is not None:
            self.first = arrived - t_s
        return None if self.first is None else self.first + t_s


class Bridge:
    """The feed's records and markers pushed into LSL outlets."""

    def __init__(self, pylsl, name: str, quantities: Sequence[str], source: str) -> None:
        self.pylsl = pylsl
        self.name = name
        self.quantities = list(quantities)
        self.source = source
        self.clock = Clock(pylsl)
        self.schema: Optional[dict] = None
        self.outlet = None
        self.markers = None
        self.sensors = 0
        self.samples = 0
        # The latest time stamp's records, held until a later one comes
        # (a block's records may arrive in two batches).
        self.held: List[list] = []
        # The last sample pushed, (segment, t_s): a backlog taken again
        # after a gap is pushed from there on only.
        self.last: Optional[Tuple[int, float]] = None
        self.folder: Optional[str] = None

    def open(self, device: dict) -> None:
        """The outlets, once the device's run is known."""
        pylsl = self.pylsl
        self.sensors = int(device["sensors"])
        names = sensor_labels(device)
        groups = device.get("groups") or [None] * self.sensors
        labels = channel_labels(names, self.quantities)
        info = pylsl.StreamInfo(self.name, "DESkin", len(labels), pylsl.IRREGULAR_RATE,
                                pylsl.cf_double64, self.source)
        desc = info.desc()
        acq = desc.append_child("acquisition")
        acq.append_child_value("manufacturer", "de-skin")
        acq.append_child_value("model", str(device.get("firmware", "")))
        acq.append_child_value("sensors", str(self.sensors))
        if device.get("skin"):
            acq.append_child_value("skin", str(device["skin"]))
        chans = desc.append_child("channels")
        for s in range(self.sensors):
            for q in self.quantities:
                unit, kind = QUANTITIES[q]
                ch = chans.append_child("channel")
                ch.append_child_value("label", "%s.%s" % (names[s], q))
                ch.append_child_value("unit", unit)
                ch.append_child_value("type", kind)
                ch.append_child_value("sensor", str(s))
                ch.append_child_value("name", names[s])
                if s < len(groups) and groups[s]:
                    ch.append_child_value("group", str(groups[s]))
                ch.append_child_value("quantity", q)
        flags = desc.append_child("flags")
        for f in (self.schema or {}).get("flags", []):
            el = flags.append_child("flag")
            el.append_child_value("bit", str(f["bit"]))
            el.append_child_value("name", f["name"])
            el.append_child_value("fault", "true" if f["fault"] else "false")
        clock = desc.append_child("clock")
        clock.append_child_value("mapping", "device time to host UTC by live's clock fit, then to LSL's clock")
        clock.append_child_value("fit", json.dumps(device.get("clock")))
        self.outlet = pylsl.StreamOutlet(info)
        minfo = pylsl.StreamInfo(self.name + " markers", "Markers", 1, pylsl.IRREGULAR_RATE,
                                 pylsl.cf_string, self.source + ":markers")
        self.markers = pylsl.StreamOutlet(minfo)

    def device(self, d: dict) -> None:
        if self.outlet is None:
            self.open(d)
        if d.get("segment") != self.clock.segment:
            self.clock.first = None
        self.clock.segment = d.get("segment")
        self.clock.fit = d.get("clock")

    def batch(self, rows: List[list], fields: List[str], last: bool = False) -> None:
        """A feed batch: its records grouped by (segment, time stamp), a
        sample each, at its time on LSL's clock; the latest time stamp's
        held for the next batch, unless `last`."""
        if self.outlet is None:
            return
        at = {n: i for i, n in enumerate(fields)}
        offset = self.clock.lsl_minus_utc()
        groups: Dict[Tuple[int, float], List[list]] = {}
        for row in self.held + rows:
            groups.setdefault((row[at["segment"]], row[at["t_s"]]), []).append(row)
        self.held = []
        if groups and not last:
            self.held = groups.pop(list(groups)[-1])
        width = len(self.quantities)
        for (segment, t_s), rs in groups.items():
            if segment != self.clock.segment:
                continue  # another run's (the backlog's): its fit is not this one
            if self.last is not None and (segment, t_s) <= self.last:
                continue  # pushed before a gap
            self.last = (segment, t_s)
            sample = [math.nan] * (self.sensors * width)
            for r in rs:
                s = r[at["sensor"]]
                if s >= self.sensors:
                    continue
                for k, q in enumerate(self.quantities):
                    v = r[at[q]]
                    sample[s * width + k] = math.nan if v is None else float(v)
            utc = self.clock.utc_of(t_s, rs[0][at["host_utc_s"]] if "host_utc_s" in at else None)
            if utc is None:
                continue
            self.outlet.push_sample(sample, utc + offset)
            self.samples += 1

    def recording(self, r: dict) -> None:
        """A recording started or stopped: its records count their
        segments anew."""
        if r.get("folder") != self.folder:
            self.folder = r.get("folder")
            self.last = None

    def marker(self, m: dict) -> None:
        if self.markers is not None:
            utc = m["host_utc_us"] * 1e-6
            self.markers.push_sample([m["text"]], utc + self.clock.lsl_minus_utc())


def post_marker(url: str, text: str, utc: float) -> None:
    """A marker written into the session through the dashboard."""
    body = json.dumps({"text": text, "source": "lsl", "host_utc_us": int(round(utc * 1e6))}).encode()
    req = urllib.request.Request(url.rstrip("/") + "/marker", data=body,
                                 headers={"Content-Type": "application/json"}, method="POST")
    with urllib.request.urlopen(req, timeout=10) as r:
        r.read()


def forward_markers(pylsl, url: str, name: str, stop: threading.Event) -> None:
    """Markers of the LSL stream `name`, posted to the session at their
    own time (their LSL time stamp mapped to the host's UTC)."""
    while not stop.is_set():
        found = pylsl.resolve_byprop("name", name, timeout=1.0)
        if found:
            break
    else:
        return
    inlet = pylsl.StreamInlet(found[0])
    while not stop.is_set():
        sample, ts = inlet.pull_sample(timeout=0.2)
        if sample is None:
            continue
        utc = ts + inlet.time_correction() - pylsl.local_clock() + time.time()
        try:
            post_marker(url, str(sample[0]), utc)
        except OSError as e:
            print("marker not written: %s" % e, file=sys.stderr)


def follow(bridge: "Bridge", base: str, quantities: Sequence[str]) -> str:
    """One connection to the feed: its events into `bridge` until it
    ends (`end`), falls behind (`gap`) or is lost (`lost`)."""
    fields: List[str] = []
    try:
        for event, data in feed.events(base + "/events", timeout=None):
            if event == "schema":
                bridge.schema = json.loads(data)
                fields = [f["name"] for f in bridge.schema["fields"]]
                if bridge.schema["version"] < feed.FEED_VERSION:
                    raise ValueError("feed version %s, this bridge reads %d on"
                                     % (bridge.schema["version"], feed.FEED_VERSION))
                missing = [q for q in quantities if q not in fields]
                if missing:
                    raise ValueError("the feed has no %s" % ", ".join(missing))
            elif event == "device":
                bridge.device(json.loads(data))
            elif event == "recording":
                bridge.recording(json.loads(data))
            elif event == "message":
                bridge.batch(json.loads(data), fields)
            elif event == "marker":
                bridge.marker(json.loads(data))
            elif event == "end":
                bridge.batch([], fields, last=True)
                return "end"
            elif event == "gap":
                return "gap"
    except OSError:
        return "lost"
    return "lost"


def run(url: str, name: str, quantities: Sequence[str], markers_from: Optional[str] = None,
        linger: float = 1.0, retry_s: float = 30.0) -> int:
    """The bridge until the feed ends: after a gap (it fell behind) it
    connects again and takes the backlog, pushing only what it had not;
    a feed lost or not yet there is tried again each second for
    `retry_s`."""
    import pylsl  # type: ignore

    base = url.rstrip("/")
    bridge = Bridge(pylsl, name, quantities, "de-skin:" + base)
    stop = threading.Event()
    if markers_from:
        threading.Thread(target=forward_markers, args=(pylsl, base, markers_from, stop), daemon=True).start()
    lost_since = None
    try:
        while True:
            how = follow(bridge, base, quantities)
            if how == "end":
                break
            if how == "gap":
                print("the bridge fell behind the feed: connecting again for the backlog", file=sys.stderr)
                bridge.held = []
                lost_since = None
                continue
            lost_since = lost_since or time.time()
            if time.time() - lost_since > retry_s:
                print("the feed at %s is gone" % base, file=sys.stderr)
                return 1
            time.sleep(1.0)
    finally:
        stop.set()
    print("%d samples pushed to LSL stream '%s'" % (bridge.samples, name), file=sys.stderr)
    # The inlets take what was pushed before the outlet goes.
    time.sleep(linger)
    return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="python -m skinread.lsl", description=__doc__.split("\n\n")[0])
    p.add_argument("url", help="the dashboard's address, as `live --serve` prints it")
    p.add_argument("--name", default="DE skin", help="the LSL stream's name")
    p.add_argument("--quantities", default=",".join(DEFAULT),
                   help="the channels per sensor, of: " + ", ".join(QUANTITIES))
    p.add_argument("--markers-from", metavar="NAME", help="write the markers of this LSL stream into the session")
    p.add_argument("--linger", type=float, default=1.0, help="seconds kept open after the feed ends")
    p.add_argument("--retry", type=float, default=30.0, metavar="S",
                   help="seconds to keep trying a feed that is lost or not there yet")
    a = p.parse_args(argv)
    qs = [q.strip() for q in a.quantities.split(",") if q.strip()]
    bad = [q for q in qs if q not in QUANTITIES]
    if bad:
        p.error("unknown quantity %s (known: %s)" % (", ".join(bad), ", ".join(QUANTITIES)))
    return run(a.url, a.name, qs, a.markers_from, a.linger, a.retry)


if __name__ == "__main__":
    sys.exit(main())
