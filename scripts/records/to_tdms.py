#!/usr/bin/env python3
"""Writes a CSV record as a LabVIEW TDMS file with npTDMS, each column a channel of the same
name in one group, in segments of SEGMENT rows as a logger streams them (the time column
included, and each channel's `wf_increment` set to the step): `bgc residuals` and
`bgc identify` read it as they read the CSV.

    scripts/records/to_tdms.py RECORD.csv RECORD.tdms [--segment ROWS]

Needs numpy and nptdms. The Python tests use it on a simulated record of the bench."""

import argparse

import numpy as np
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

import record_csv  # this folder's, next to the script


def convert(source: str, target: str, segment: int) -> None:
    header, values = record_csv.read(source)
    step = float(np.median(np.diff(values[:, 0]))) if len(values) > 1 else 0.0
    group = "record"
    with TdmsWriter(target) as writer:
        for start in range(0, len(values), segment):
            block = values[start:start + segment]
            objects = [RootObject(properties={"source": source}), GroupObject(group)]
            for k, name in enumerate(header):
                objects.append(ChannelObject(group, name, block[:, k],
                                             properties={"wf_increment": step}))
            writer.write_segment(objects)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source")
    parser.add_argument("target")
    parser.add_argument("--segment", type=int, default=4096, help="rows per segment")
    args = parser.parse_args()
    convert(args.source, args.target, args.segment)


if __name__ == "__main__":
    main()
