#!/usr/bin/python3
"""tgrid.py FILE [EXPR] — read a grid file (docs/grid-format.md) with NumPy
and print EXPR evaluated with level, step, time and the channels (by
name, H x W x width arrays) in scope; without EXPR, print a summary.
For the end-to-end tests' checks of simulate-peer's output."""
import sys

import numpy as np

import gridfile


def read(path):
    try:
        g = gridfile.read(path)
    except ValueError as e:
        sys.exit(f"{path}: {e}")
    return g["level"], g["step"], g["time"], g["channels"]


if __name__ == "__main__":
    level, step, time, ch = read(sys.argv[1])
    if len(sys.argv) > 2:
        scope = dict(ch, level=level, step=step, time=time, np=np)
        print(eval(sys.argv[2], {}, scope))
    else:
        print(f"level {level} step {step} time {time:.9g} channels {' '.join(ch)}")
