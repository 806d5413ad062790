#!/usr/bin/python3
"""tgrid.py FILE [EXPR] — read a grid file (docs/grid-format.md) with NumPy
and print EXPR evaluated with level, step, time and the channels (by
name, H x W x width arrays) in scope; without EXPR, print a summary.
For the end-to-end tests' checks of simulate-peer's output."""
import struct
import sys

import numpy as np


def read(path):
    b = open(path, "rb").read()
    if b[:8] != b"\x89NDO\r\n\x1a\n":
        sys.exit(f"{path}: not a grid file")
    level, nch, hlen = struct.unpack_from("<III", b, 12)
    step, time = struct.unpack_from("<qd", b, 24)
    off, chans = 64, []
    for _ in range(nch):
        name = b[off:off + 16].split(b"\0")[0].decode()
        chans.append((name, b[off + 16], b[off + 17]))
        off += 32
    off += (hlen + 7) // 8 * 8
    n = 1 << level
    w, h = 2 * n + 1, n + 1
    out = {}
    for name, typ, width in chans:
        dtype, size = {1: ("<f8", 8), 2: ("<f4", 4), 3: ("u1", 1), 4: ("<i4", 4)}[typ]
        count = w * h * width
        out[name] = np.frombuffer(b, dtype, count, off).reshape(h, w, width)
        off += (count * size + 7) // 8 * 8
    return level, step, time, out


if __name__ == "__main__":
    level, step, time, ch = read(sys.argv[1])
    if len(sys.argv) > 2:
        scope = dict(ch, level=level, step=step, time=time, np=np)
        print(eval(sys.argv[2], {}, scope))
    else:
        print(f"level {level} step {step} time {time:.9g} channels {' '.join(ch)}")
