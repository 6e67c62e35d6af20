"""A data set folder (docs/data-format.md, "A data set"; a `live`
session's or `host-sim decode`'s) into pandas."""

from __future__ import annotations

import glob
import json
import os
import re
from typing import Dict, List, Tuple

import numpy as np
import pandas as pd

from .stream import with_flag_names, with_generation


def _read(path: str) -> pd.DataFrame:
    df = pd.read_csv(path, comment="#", skipinitialspace=True)
    df.columns = [c.strip() for c in df.columns]
    if "flags" in df.columns:
        df = df.rename(columns={"flags": "flag_bits"})
        df = with_flag_names(df)
    return df


def _manifest(folder: str) -> dict:
    path = os.path.join(folder, "session.json")
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        return json.load(f)


def skin(folder: str) -> pd.DataFrame:
    """The skin's sensors of a `live --skin` session (its manifest): a
    row per sensor with its `sensor` index, `name`, `group` and place
    (`x`, `y`, in the skin's units); empty without a skin."""
    sensors = (_manifest(folder).get("skin") or {}).get("sensors", [])
    rows = [
        {"sensor": s["index"], "name": s["name"], "group": s.get("group"),
         "x": s["place"][0], "y": s["place"][1]}
        for s in sensors
    ]
    return pd.DataFrame(rows, columns=["sensor", "name", "group", "x", "y"])


def clocks(folder: str) -> Dict[int, dict]:
    """Each segment's clock fit from a `live` session's manifest
    (`session.json`): {segment: its `clock` (offset_unix_s, rate,
    sigma_offset_ms, drift_ppm, ...)}, for the segments that have one."""
    segments = _manifest(folder).get("segments", [])
    return {k + 1: g["clock"] for k, g in enumerate(segments) if g.get("clock")}


def in_force(folder: str) -> Dict[int, List[Tuple[int, int]]]:
    """Each segment's stored sets in force from a `live` session's
    manifest: {segment: [(sequence number after which it holds,
    generation)]}, the start's first, then each set the device applied
    while it ran."""
    segments = _manifest(folder).get("segments", [])
    return {
        k + 1: [(c["from_seq"], c["generation"]) for c in g.get("settings_in_force", [])]
        for k, g in enumerate(segments)
    }


def _utc_of_us(us: pd.Series) -> pd.Series:
    """µs since the epoch (float, NaN for none) as UTC times, to the µs."""
    return pd.to_datetime(us.round().astype("Int64") * 1000, unit="ns", utc=True)


def with_utc(df: pd.DataFrame, folder: str, time_s: pd.Series) -> pd.DataFrame:
    """`t_utc`: each row's device time (`time_s`, s) on the host's UTC
    by its segment's clock fit (NaT where its segment has none)."""
    fits = clocks(folder)
    seg = df["segment"] if "segment" in df.columns else pd.Series(1, index=df.index)
    offset = seg.map(lambda g: fits.get(int(g), {}).get("offset_unix_s", np.nan))
    rate = seg.map(lambda g: fits.get(int(g), {}).get("rate", np.nan))
    df["t_utc"] = _utc_of_us((offset + rate * time_s) * 1e6)
    return df


def read_records(folder: str) -> pd.DataFrame:
    """`records.csv` of a `live` session: every record as it arrived,
    `flag_bits`, `valid` and a boolean column per flag; `arrived_utc`,
    the host's UTC when it arrived, and `t_utc`, its own time stamp on
    the host's UTC by its segment's clock fit (the manifest's);
    `generation`, the stored set it was measured with (the manifest's
    sets in force; -1 where it does not say); with a skin (`live
    --skin`), each sensor's `name`."""
    df = _read(os.path.join(folder, "records.csv"))
    with_generation(df, in_force(folder))
    if "host_utc_us" in df.columns:
        df["arrived_utc"] = _utc_of_us(df["host_utc_us"].astype("float64"))
    names = skin(folder)
    if len(names):
        df["name"] = df["sensor"].map(dict(zip(names["sensor"], names["name"])))
    return with_utc(df, folder, df["t_us"] * 1e-6)


def read_markers(folder: str) -> pd.DataFrame:
    """`markers.csv` of a `live` session: each marker's text and source,
    `host_utc` (when it was made) and `device_t_us` (the device's time
    there, by the clock fit when it was made)."""
    df = pd.read_csv(os.path.join(folder, "markers.csv"), dtype={"text": str, "source": str}, keep_default_na=False,
                     na_values={"device_t_us": [""]})
    df["host_utc"] = _utc_of_us(df["host_utc_us"].astype("float64"))
    return df


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
    out = out.sort_values(keys, kind="stable").reset_index(drop=True)
    if "time_s" in out.columns and clocks(folder):
        out = with_utc(out, folder, out["time_s"])
    return out


def by_sensor(df: pd.DataFrame) -> Dict[int, pd.DataFrame]:
    """One frame per sensor (its tones' rows together, in time)."""
    key = "t_us" if "t_us" in df.columns else "time_s"
    return {
        int(s): g.sort_values(key, kind="stable").reset_index(drop=True)
        for s, g in df.groupby("sensor")
    }


def read_skin(folder: str) -> pd.DataFrame:
    """The skin's `records.csv` of a session of several boards (`live
    --skin FILE --source NAME=…`): every board's records, keyed by
    `board` and `sensor` (with the sensor's `name`), `t_utc` the
    record's time on the host's UTC through its board's clock fit (NaT
    where its segment has none), `arrived_utc`, and the flags decoded as
    in `read_records`. Each board's own session is `folder/<board>/`."""
    df = _read(os.path.join(folder, "records.csv"))
    if "board" not in df.columns or "t_utc_us" not in df.columns:
        raise ValueError(f"{folder}/records.csv: not a skin's records (no board, t_utc_us columns)")
    df["board"] = df["board"].astype(str)
    df["t_utc"] = _utc_of_us(df["t_utc_us"].astype("float64"))
    if "host_utc_us" in df.columns:
        df["arrived_utc"] = _utc_of_us(df["host_utc_us"].astype("float64"))
    return df


def boards(folder: str) -> pd.DataFrame:
    """The boards of a session of several (its `skin.json`): a row per
    board with its `folder`, `device` (the first segment's id, hex),
    `records`, `reconnects`, `complete`, and its first segment's clock
    (`offset_unix_s`, `drift_ppm`, `sigma_offset_ms`)."""
    with open(os.path.join(folder, "skin.json")) as f:
        manifest = json.load(f)
    rows = []
    for b in manifest["boards"]:
        clock = (b.get("clock") or [None])[0] or {}
        rows.append({
            "board": b["board"], "folder": b.get("folder"),
            "device": (b.get("devices") or [None])[0], "records": b.get("records"),
            "reconnects": b.get("reconnects"), "complete": b.get("complete"),
            "offset_unix_s": clock.get("offset_unix_s"), "drift_ppm": clock.get("drift_ppm"),
            "sigma_offset_ms": clock.get("sigma_offset_ms"),
        })
    return pd.DataFrame(rows)
