#!/usr/bin/env python3
"""Writes a CSV record as an ASAM MDF 4 file with asammdf: the signals in one channel group
whose master channel is the time column, as a logger records them (`--compress` zips the data
blocks, transposed, as asammdf's `compression=2` does): `bgc residuals` and `bgc identify`
read it as they read the CSV, the master as the time.

    scripts/records/to_mdf.py RECORD.csv RECORD.mf4 [--compress]

Needs numpy and asammdf. The Python tests use it on a simulated record of the bench."""

import argparse

from asammdf import MDF, Signal

import record_csv  # this folder's, next to the script


def convert(source: str, target: str, compress: bool) -> None:
    header, values = record_csv.read(source)
    time = values[:, header.index("t")]
    signals = [Signal(values[:, k], time, name=name) for k, name in enumerate(header) if name != "t"]
    mdf = MDF(version="4.10")
    mdf.append(signals, comment=f"from {source}")
    mdf.save(target, overwrite=True, compression=2 if compress else 0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source")
    parser.add_argument("target")
    parser.add_argument("--compress", action="store_true", help="transpose and zip the data")
    args = parser.parse_args()
    convert(args.source, args.target, args.compress)


if __name__ == "__main__":
    main()
