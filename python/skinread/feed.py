"""The dashboard's live feed (docs/live.md, "The live feed"): server-sent
events at `http://HOST:PORT/events` while `live --serve` runs. Version 2:
a `schema` event (the fields of a record and the flags by name), then
`backlog` (how many records came before those sent next), batches of
records (default events: a JSON array of rows, each the schema's fields
in order), `cpu` and `valid` (the device's CPU and each sensor's share
valid, as JSON), `device` (the device's run: sensors, firmware, and its
clock fitted to the host's UTC), `marker` (a marker written), `gap` (the
client fell behind: reconnect) and `end`. A version only adds fields at
the end of a record and new events: this client reads any version from
its own on, by the fields' names.
"""

from __future__ import annotations

import json
import urllib.request
from typing import Iterator, Optional, Tuple

from .flags import names

#: The feed version this client reads.
FEED_VERSION = 2


def events(url: str, timeout: Optional[float] = 30.0) -> Iterator[Tuple[str, str]]:
    """(event, data) pairs from a server-sent event stream."""
    with urllib.request.urlopen(url, timeout=timeout) as resp:
        name, data = "message", []
        for raw in resp:
            line = raw.decode("utf-8").rstrip("\r\n")
            if not line:
                if data:
                    yield name, "\n".join(data)
                name, data = "message", []
            elif line.startswith(":"):
                continue
            elif line.startswith("event:"):
                name = line[6:].strip()
            elif line.startswith("data:"):
                data.append(line[5:].lstrip(" "))


def records(url: str, timeout: Optional[float] = 30.0) -> Iterator[dict]:
    """Each record of the feed as a dict keyed by the schema's field
    names, with `flags` as the names of the bits set and `valid`, until
    the feed ends; other events as `{"event": name, "data": …}`."""
    fields = None
    faults = 0
    for name, data in events(url, timeout):
        if name == "schema":
            schema = json.loads(data)
            if schema["version"] < FEED_VERSION:
                raise ValueError("feed version %s, this client reads %d on" % (schema["version"], FEED_VERSION))
            fields = [f["name"] for f in schema["fields"]]
            faults = sum(1 << f["bit"] for f in schema["flags"] if f["fault"])
        elif name == "message":
            if fields is None:
                raise ValueError("records before the schema: not a version-%d feed" % FEED_VERSION)
            for row in json.loads(data):
                r = dict(zip(fields, row))
                r["flags"] = names(r["flag_bits"])
                r["valid"] = r["flag_bits"] & faults == 0
                yield r
        elif name == "end":
            return
        else:
            yield {"event": name, "data": data}
