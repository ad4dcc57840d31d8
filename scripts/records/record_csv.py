"""A CSV record read as `bgc simulate` writes it: a header, then rows of numbers (lines
starting with `#` are comments). Shared by the converters of this folder."""

import csv
from typing import List, Tuple

import numpy as np


def read(source: str) -> Tuple[List[str], np.ndarray]:
    """The header and the values of the CSV record at `source`, a row per sample."""
    with open(source, newline="") as f:
        rows = csv.reader(line for line in f if not line.startswith("#"))
        header = next(rows)
        values = np.array([[float(c) for c in row] for row in rows if row], dtype=float)
    return header, values
