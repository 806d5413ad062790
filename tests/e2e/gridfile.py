"""The grid file from Python, for the tests and docs scripts.

read_grid(f) is the NumPy reader printed in docs/grid-format.md, executed
from the document itself, so the code a user copies is the code the tests
run.  read(path) opens a file for it; write_grid(path, g) writes the same
format (g: level, step, time, history and ch, name -> H x W x width array)."""
import os
import re
import struct
import zlib

import numpy as np

_DOC = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'docs',
                    'grid-format.md')
with open(_DOC, encoding='utf-8') as _f:
    _code = re.search(r'<!-- numpy-reader -->\s*```python\n(.*?)```', _f.read(), re.S).group(1)
exec(_code)  # defines read_grid(f)

MAGIC = b'\x89NDO\r\n\x1a\n'
CODES = {np.dtype('<f8'): 1, np.dtype('<f4'): 2, np.dtype('u1'): 3, np.dtype('<i4'): 4}


def read(path):
    """The grid in the file at path (a dict, as read_grid returns)."""
    with open(path, 'rb') as f:
        return read_grid(f)  # noqa: F821 (defined by the document's code)


def _pad8(n):
    return (n + 7) & ~7


def write_grid(path, g):
    table = payload = b''
    for name, a in g['ch'].items():
        a = np.ascontiguousarray(a)
        table += name.encode().ljust(16, b'\0') + bytes([CODES[a.dtype], a.shape[2]]) + bytes(14)
        d = a.tobytes()
        payload += d + bytes(_pad8(len(d)) - len(d))
    hist = g['history'].encode()
    body = table + hist + bytes(_pad8(len(hist)) - len(hist)) + payload
    head = MAGIC + struct.pack('<HHIIIqdQ', 1, 64, g['level'], len(g['ch']), len(hist),
                               g['step'], g['time'], len(payload)) + bytes(12)
    head += struct.pack('<I', zlib.crc32(head))
    with open(path, 'wb') as f:
        f.write(head + body + struct.pack('<I', zlib.crc32(body)) + b'END\n')
