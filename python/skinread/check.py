"""Check a `live` session's records.csv against its raw stream
(stream.bin), decoded by this package: the same records, field by
field. `python -m skinread.check SESSION_DIR` prints the count and exits
non-zero on the first disagreement.
"""

from __future__ import annotations

import math
import os
import sys
from typing import List

import numpy as np
import pandas as pd

from .dataset import read_records
from .stream import read_stream

#: The integer columns, equal exactly.
INTS = ["segment", "seq", "t_us", "sensor"]
#: The f32 fields, written in their shortest form: equal as f32.
F32 = ["f1_hz", "z1_re_ohm", "z1_im_ohm", "f2_hz", "z2_re_ohm", "z2_im_ohm",
       "r_ohm", "stretch_mm", "chosen_hz", "chi2", "sigma_ln_c"]


def agree(folder: str) -> int:
    """The records both agree on; raises AssertionError naming the
    first record and field they do not."""
    ours, _ = read_stream(os.path.join(folder, "stream.bin"))
    theirs = pd.read_csv(os.path.join(folder, "records.csv"))
    assert len(ours) == len(theirs), "records: %d decoded, %d in records.csv" % (len(ours), len(theirs))
    for c in INTS:
        bad = np.flatnonzero(ours[c].to_numpy() != theirs[c].to_numpy())
        assert bad.size == 0, "row %d: %s %s != %s" % (bad[0], c, ours[c].iat[bad[0]], theirs[c].iat[bad[0]])
    bad = np.flatnonzero(ours["flag_bits"].to_numpy() != theirs["flags"].to_numpy())
    assert bad.size == 0, "row %d: flags" % bad[0]
    # The arrival times, to the µs (none on either side where the
    # session kept no arrivals).
    a = ours["host_utc_us"].to_numpy(dtype=np.float64)
    b = theirs.get("host_utc_us", pd.Series(np.nan, index=theirs.index)).to_numpy(dtype=np.float64)
    bad = np.flatnonzero(~((a == b) | (np.isnan(a) & np.isnan(b))))
    assert bad.size == 0, "row %d: host_utc_us %r != %r" % (bad[0], a[bad[0]], b[bad[0]])
    for c in F32:
        a = ours[c].to_numpy(dtype=np.float32)
        b = theirs[c].to_numpy(dtype=np.float64).astype(np.float32)
        same = (a == b) | (~np.isfinite(a) & np.isnan(b))
        bad = np.flatnonzero(~same)
        assert bad.size == 0, "row %d: %s %r != %r" % (bad[0], c, a[bad[0]], b[bad[0]])
    # The stored set each record was measured with: from the stream's
    # start and applied frames here, from the manifest there.
    # (A records file without its manifest says -1: not compared.)
    gen = read_records(folder)["generation"].to_numpy()
    bad = np.flatnonzero((ours["generation"].to_numpy() != gen) & (gen >= 0))
    assert bad.size == 0, "row %d: generation %r != %r" % (bad[0], ours["generation"].iat[bad[0]], gen[bad[0]])
    # C in pF, four decimals of the f32's value.
    a = ours["c_pf"].to_numpy()
    b = theirs["c_pf"].to_numpy(dtype=np.float64)
    same = (np.abs(a - b) <= 0.5e-4 + 1e-9 * np.abs(a)) | (~np.isfinite(a) & np.isnan(b))
    bad = np.flatnonzero(~same)
    assert bad.size == 0, "row %d: c_pf %r != %r" % (bad[0], a[bad[0]], b[bad[0]])
    return len(ours)


def main(argv: List[str]) -> int:
    if len(argv) != 2:
        print("usage: python -m skinread.check SESSION_DIR", file=sys.stderr)
        return 2
    try:
        n = agree(argv[1])
    except AssertionError as e:
        print("disagree: %s" % e, file=sys.stderr)
        return 1
    print("agree: %d records, field by field" % n)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
