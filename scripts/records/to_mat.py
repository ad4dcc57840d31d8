#!/usr/bin/env python3
"""Writes a CSV record as a Matlab level-5 `.mat` file with scipy, each column a variable of
the same name (a column vector), as a logger's export or `save(FILE, '-v7')` would hold it:
`bgc residuals` and `bgc identify` read it as they read the CSV.

    scripts/records/to_mat.py RECORD.csv RECORD.mat [--compress]

Needs numpy and scipy. The Python tests use it on a simulated record of the bench, and it
converts the EMPS records of the docs (which stay out of the repository)."""

import argparse

import scipy.io

import record_csv  # this folder's, next to the script


def convert(source: str, target: str, compress: bool) -> None:
    header, values = record_csv.read(source)
    variables = {name: values[:, k].reshape(-1, 1) for k, name in enumerate(header)}
    scipy.io.savemat(target, variables, do_compression=compress, oned_as="column")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source")
    parser.add_argument("target")
    parser.add_argument("--compress", action="store_true", help="zlib-compress each variable (-v7)")
    args = parser.parse_args()
    convert(args.source, args.target, args.compress)


if __name__ == "__main__":
    main()
