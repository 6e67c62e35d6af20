"""python -m labgen --seed N [--family NAME|clean] --out DIR

Writes one data set and its truth.json (the family, its value, the
catalogue ids that name it right, the meter kernel's centroid and the
row interval). Without --family the survey's plan picks it from the
seed."""

import argparse
import json
import os
import sys

from . import families
from .bench import ROW_S, Bench


def main(argv=None):
    ap = argparse.ArgumentParser(prog="labgen", description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--family", help="a family name, or 'clean' (default: the survey's plan)")
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    fam, rng = families.plan(a.seed)
    if a.family is not None:
        fam = None if a.family == "clean" else a.family
        if fam is not None and fam not in families.FAMILIES:
            ap.error(f"no family {fam!r}; one of: clean, {', '.join(families.FAMILIES)}")
    fx, meter, value = families.draw(fam, rng)
    Bench(effects=fx, meter=meter, seed=a.seed).write(a.out)
    ids, what = families.FAMILIES.get(fam, ([], "nothing added"))
    truth = {
        "generator": "labgen",
        "seed": a.seed,
        "family": fam or "clean",
        "what": what,
        "value": value,
        "catalogue_ids": ids,
        "outside": fam is not None and not ids,
        "kernel_centroid_s": meter.centroid_s(ROW_S),
        "row_s": ROW_S,
    }
    with open(os.path.join(a.out, "truth.json"), "w") as fh:
        json.dump(truth, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
