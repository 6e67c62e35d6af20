"""The records' flags (docs/data-format.md, "Flags"): bit, name."""

from __future__ import annotations

from typing import List

#: (bit, name) of every flag.
FLAGS = (
    (0, "CLIPPED"),
    (1, "OPEN"),
    (2, "SHORTED"),
    (3, "RANGE"),
    (4, "SETTLING"),
    (5, "HELD"),
    (6, "DISTURBED"),
    (7, "UNCERTAIN"),
    (8, "MODEL"),
    (9, "UNCALIBRATED"),
    (10, "OFF_TABLE"),
    (11, "LATE"),
    (12, "TONE_LEFT_OUT"),
    (13, "TONE_MOVED"),
    (14, "SELF_TEST"),
)

#: The fault bits: C and R are valid when none is set.
FAULTS = 0b100_1000_1111_1111
#: The bits that keep the stretch from being vouched for (faults and
#: the stretch's statuses).
STRETCH_FAULTS = 0b100_1111_1111_1111


def names(bits: int) -> List[str]:
    """The names of the flags set in `bits`, in bit order."""
    return [name for bit, name in FLAGS if bits >> bit & 1]


def valid(bits: int) -> bool:
    """C and R stand: no fault bit set."""
    return bits & FAULTS == 0
