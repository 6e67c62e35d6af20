"""A data set folder (docs/data-format.md, "A data set"; a `live`
session's or `host-sim decode`'s) into pandas."""

from __future__ import annotations

import glob
import json
import os
import re
from typing import Dict

import pandas as pd

from .stream import with_flag_names


def _read(path: str) -> pd.DataFrame:
    df = pd.read_csv(path, comment="#", skipinitialspace=True)
    df.columns = [c.strip() for c in df.columns]
    if "flags" in df.columns:
        df = df.rename(columns={"flags": "flag_bits"})
        df = with_flag_names(df)
    return df


def read_records(folder: str) -> pd.DataFrame:
    """`records.csv` of a `live` session: every record as it arrived,
    `flag_bits`, `valid` and a boolean column per flag."""
    return _read(os.path.join(folder, "records.csv"))


def read_traces(folder: str) -> Dict[str, pd.DataFrame]:
    """Each `trace_*.csv` of a data set by file name, flags by name where
    the file has them, in the order of their names."""
    return {
        os.path.basename(p): _read(p)
        for p in sorted(glob.glob(os.path.join(folder, "trace_*.csv")))
    }


_TRACE = re.compile(r"trace_(?:s(?P<segment>\d+)_)?ch(?P<sensor>\d+)_")


def read_dataset(folder: str) -> pd.DataFrame:
    """A data set's traces in one frame, a row per reading, with `file`,
    `sensor` (from `dataset.json` where it says, else the file's name)
    and `segment` columns: a sensor's trace across its tone files is one
    sensor, and the whole skin one frame."""
    meta: dict = {}
    path = os.path.join(folder, "dataset.json")
    if os.path.exists(path):
        with open(path) as f:
            meta = json.load(f)
    described = {t.get("file"): t for t in meta.get("traces", []) if isinstance(t, dict)}
    frames = []
    for name, df in read_traces(folder).items():
        d = described.get(name, {})
        m = _TRACE.match(name)
        sensor = d.get("sensor", int(m["sensor"]) if m else None)
        segment = d.get("segment", int(m["segment"]) if m and m["segment"] else 1)
        frames.append(df.assign(file=name, sensor=sensor, segment=segment))
    if not frames:
        return pd.DataFrame()
    out = pd.concat(frames, ignore_index=True)
    keys = [c for c in ("segment", "sensor", "time_s") if c in out.columns]
    return out.sort_values(keys, kind="stable").reset_index(drop=True)


def by_sensor(df: pd.DataFrame) -> Dict[int, pd.DataFrame]:
    """One frame per sensor (its tones' rows together, in time)."""
    key = "t_us" if "t_us" in df.columns else "time_s"
    return {
        int(s): g.sort_values(key, kind="stable").reset_index(drop=True)
        for s, g in df.groupby("sensor")
    }
