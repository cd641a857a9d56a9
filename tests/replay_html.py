"""Reading a recorded Meshcat replay (``meshcat.StaticHtml()``) back: its commands, msgpack
messages embedded as base64 ``data:`` URLs, decoded here without a msgpack package."""

from __future__ import annotations

import base64
import re
import struct
from pathlib import Path

_DATA_URL = re.compile(rb'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)')


class _Reader:
    """A minimal msgpack decoder (the types Meshcat's messages use)."""

    def __init__(self, data: bytes) -> None:
        self.data, self.pos = data, 0

    def take(self, n: int) -> bytes:
        chunk = self.data[self.pos : self.pos + n]
        if len(chunk) != n:
            raise ValueError(f"msgpack: truncated at byte {self.pos}")
        self.pos += n
        return chunk

    def unpack(self, fmt: str):
        return struct.unpack(">" + fmt, self.take(struct.calcsize(">" + fmt)))[0]

    def value(self):
        b = self.take(1)[0]
        if b <= 0x7F:
            return b
        if b >= 0xE0:
            return b - 0x100
        if 0x80 <= b <= 0x8F:
            return self.map(b & 0x0F)
        if 0x90 <= b <= 0x9F:
            return [self.value() for _ in range(b & 0x0F)]
        if 0xA0 <= b <= 0xBF:
            return self.take(b & 0x1F).decode()
        fixed = {0xC0: None, 0xC2: False, 0xC3: True}
        if b in fixed:
            return fixed[b]
        scalars = {0xCA: "f", 0xCB: "d", 0xCC: "B", 0xCD: "H", 0xCE: "I", 0xCF: "Q"}
        scalars |= {0xD0: "b", 0xD1: "h", 0xD2: "i", 0xD3: "q"}
        if b in scalars:
            return self.unpack(scalars[b])
        sizes = {0xC4: "B", 0xC5: "H", 0xC6: "I", 0xD9: "B", 0xDA: "H", 0xDB: "I"}
        if b in sizes:
            raw = self.take(self.unpack(sizes[b]))
            return raw if b in (0xC4, 0xC5, 0xC6) else raw.decode()
        if b in (0xDC, 0xDD):
            return [self.value() for _ in range(self.unpack("H" if b == 0xDC else "I"))]
        if b in (0xDE, 0xDF):
            return self.map(self.unpack("H" if b == 0xDE else "I"))
        ext = {0xD4: 1, 0xD5: 2, 0xD6: 4, 0xD7: 8, 0xD8: 16}
        if b in ext or b in (0xC7, 0xC8, 0xC9):
            n = ext[b] if b in ext else self.unpack({0xC7: "B", 0xC8: "H", 0xC9: "I"}[b])
            kind = self.unpack("b")
            return ("ext", kind, self.take(n))
        raise ValueError(f"msgpack: unsupported type byte {b:#x} at {self.pos - 1}")

    def map(self, n: int) -> dict:
        return {self.value(): self.value() for _ in range(n)}


def replay_messages(path: str | Path) -> list:
    """The decoded Meshcat messages of a replay page, in order."""
    html = Path(path).read_bytes()
    return [_Reader(base64.b64decode(m)).value() for m in _DATA_URL.findall(html)]
