"""Byte-level makers of hostile files: PNG and JPEG with any declared size, XXH64 to re-sign map
files after changing a field (so a reader gets past the checksum to the field under test), and
text helpers. Only the standard library: the runner must work on a bare Debian with python3."""

import os
import struct
import zlib
from pathlib import Path

# ---------------------------------------------------------------------------------------------
# XXH64, written from the published specification (xxhash.com, "XXH64 algorithm"). The map's
# manifest, chunk and keyframe files carry it; without it every forged field would only test the
# checksum check.
_P1 = 11400714785074694791
_P2 = 14029467366897019727
_P3 = 1609587929392839161
_P4 = 9650029242287828579
_P5 = 2870177450012600261
_M = (1 << 64) - 1


def _rotl(x, r):
    return ((x << r) | (x >> (64 - r))) & _M


def _round(acc, lane):
    acc = (acc + lane * _P2) & _M
    return (_rotl(acc, 31) * _P1) & _M


def _merge(acc, v):
    acc ^= _round(0, v)
    return (acc * _P1 + _P4) & _M


def xxh64(data: bytes, seed: int = 0) -> int:
    n, i = len(data), 0
    if n >= 32:
        v = [(seed + _P1 + _P2) & _M, (seed + _P2) & _M, seed & _M, (seed - _P1) & _M]
        while i + 32 <= n:
            lanes = struct.unpack_from("<4Q", data, i)
            v = [_round(v[k], lanes[k]) for k in range(4)]
            i += 32
        h = (_rotl(v[0], 1) + _rotl(v[1], 7) + _rotl(v[2], 12) + _rotl(v[3], 18)) & _M
        for k in range(4):
            h = _merge(h, v[k])
    else:
        h = (seed + _P5) & _M
    h = (h + n) & _M
    while i + 8 <= n:
        h ^= _round(0, struct.unpack_from("<Q", data, i)[0])
        h = (_rotl(h, 27) * _P1 + _P4) & _M
        i += 8
    if i + 4 <= n:
        h ^= (struct.unpack_from("<I", data, i)[0] * _P1) & _M
        h = (_rotl(h, 23) * _P2 + _P3) & _M
        i += 4
    while i < n:
        h ^= (data[i] * _P5) & _M
        h = (_rotl(h, 11) * _P1) & _M
        i += 1
    h ^= h >> 33
    h = (h * _P2) & _M
    h ^= h >> 29
    h = (h * _P3) & _M
    return h ^ (h >> 32)


# ---------------------------------------------------------------------------------------------
# Map files (layouts from src/chungs/store/*.hpp).


def manifest_text(body: str) -> str:
    """A manifest body (every line before `end`) with a correct end line, as the store writes it."""
    entries = sum(1 for line in body.splitlines() if line.split()[:1] in (["config"], ["chunk"]))
    return body + "end %d %016x\n" % (entries, xxh64(body.encode()))


def manifest_body(path: Path) -> str:
    text = path.read_text()
    return text[: text.rindex("\nend ") + 1]


# Chunk header: magic | version u32 | header size u32 | id u64 | count u64 | sh u32 | flags u32 |
# payload bytes u64 | raw bytes u64 | payload xxh64 u64 | header xxh64 u64 (72 bytes).
CHUNK_FMT = "<8sIIQQIIQQQQ"
CHUNK_FIELDS = ("magic", "version", "header_size", "id", "count", "sh", "flags", "payload", "raw", "psum", "hsum")
CHUNK_HEADER = struct.calcsize(CHUNK_FMT)
# Keyframe header: magic | version | header size | id u64 | colour w h c, depth w h c (i32) | flags |
# reserved | payload bytes | raw bytes | payload xxh64 | header xxh64 (88 bytes).
KEYFRAME_FMT = "<8sIIQiiiiiiIIQQQQ"
KEYFRAME_FIELDS = ("magic", "version", "header_size", "id", "cw", "ch", "cc", "dw", "dh", "dc", "flags", "reserved",
                   "payload", "raw", "psum", "hsum")
KEYFRAME_HEADER = struct.calcsize(KEYFRAME_FMT)


def _resign(path: Path, fmt: str, names, payload=None, **changes):
    data = path.read_bytes()
    size = struct.calcsize(fmt)
    h = dict(zip(names, struct.unpack_from(fmt, data)))
    body = data[size:]
    if payload is not None:
        body = payload
        h["payload"], h["psum"] = len(payload), xxh64(payload)
    h.update(changes)
    unsigned = struct.pack(fmt, *[h[n] for n in names])
    h["hsum"] = xxh64(unsigned[: size - 8])
    path.write_bytes(struct.pack(fmt, *[h[n] for n in names]) + body)


def chunk_payload_bytes(count: int, flags: int) -> int:
    """chunk_codec.cpp's size of a payload of `count` Gaussians: a forged count passes the header's
    own consistency check only with the matching raw size."""
    params, sh_rest, raw_params = 59, 45, 11
    size = 4 * count * 4
    size += 4 * count * (raw_params + 3) + 4 + 2 * count * sh_rest if flags & 8 else 4 * count * params
    size += 2 * (5 * 4 + 2 * count * params) if flags & 4 else 2 * 4 * count * params
    return size


def resign_chunk(path: Path, payload=None, **changes):
    """Rewrites a chunk file's header fields and signs the header (and a new payload) again."""
    _resign(path, CHUNK_FMT, CHUNK_FIELDS, payload, **changes)


def resign_keyframe(path: Path, payload=None, **changes):
    _resign(path, KEYFRAME_FMT, KEYFRAME_FIELDS, payload, **changes)


def chunk_header(path: Path) -> dict:
    return dict(zip(CHUNK_FIELDS, struct.unpack_from(CHUNK_FMT, path.read_bytes())))


# ---------------------------------------------------------------------------------------------
# Images.


def _png_chunk(tag: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


_COLOR_TYPES = {1: 0, 2: 4, 3: 2, 4: 6}  # channels -> PNG colour type


def png(width: int, height: int, channels: int = 3, bit_depth: int = 8, rows: int = None, fill: int = 128) -> bytes:
    """A PNG whose header declares width x height; only `rows` rows of pixel data follow (all of them
    by default), so a tiny file can announce a huge image."""
    rows = height if rows is None else rows
    row_bytes = width * channels * bit_depth // 8
    raw = b"".join(b"\0" + bytes([fill]) * row_bytes for _ in range(rows))
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, _COLOR_TYPES[channels], 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", ihdr) + _png_chunk(b"IDAT", zlib.compress(raw, 9))
            + _png_chunk(b"IEND", b""))


def png_bad_crc(width: int, height: int, channels: int = 3) -> bytes:
    data = bytearray(png(width, height, channels))
    data[29] ^= 0xFF  # the IHDR checksum's first byte (8 magic + 8 length/tag + 13 header)
    return bytes(data)


def jpeg_header(width: int, height: int, components: int = 3) -> bytes:
    """A baseline JPEG that declares width x height and carries a few bytes of scan data: enough
    for a decoder to read the header and size its buffers (libjpeg supplies standard Huffman tables
    when a file has none, as Motion-JPEG frames do)."""
    dqt = b"\xff\xdb" + struct.pack(">H", 67) + b"\x00" + bytes([1] * 64)
    comps = b"".join(bytes([k + 1, 0x11, 0]) for k in range(components))
    sof = b"\xff\xc0" + struct.pack(">HBHHB", 8 + 3 * components, 8, height, width, components) + comps
    sos_comps = b"".join(bytes([k + 1, 0x00]) for k in range(components))
    sos = b"\xff\xda" + struct.pack(">HB", 6 + 2 * components, components) + sos_comps + b"\x00\x3f\x00"
    return b"\xff\xd8" + dqt + sof + sos + b"\x00" * 64 + b"\xff\xd9"


# ---------------------------------------------------------------------------------------------
# Files and folders.


def write(path: Path, data) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    path.write_bytes(data)


def truncate(path: Path, keep) -> None:
    """Keeps the first `keep` bytes (an int) or that share of the file (a float)."""
    data = path.read_bytes()
    n = keep if isinstance(keep, int) else int(len(data) * keep)
    path.write_bytes(data[:n])


def flip_byte(path: Path, offset: int) -> None:
    data = bytearray(path.read_bytes())
    data[offset % len(data)] ^= 0x5A
    path.write_bytes(bytes(data))


def replace_in(path: Path, old: str, new: str, count: int = 1) -> None:
    text = path.read_text()
    if old not in text:
        raise AssertionError("%s does not contain %r" % (path, old))
    path.write_text(text.replace(old, new, count))


def edit_lines(path: Path, fn) -> None:
    """Applies fn to the list of data lines (comments kept in place) and writes the file back."""
    lines = path.read_text().splitlines()
    head = [line for line in lines if line.startswith("#")]
    data = [line for line in lines if line and not line.startswith("#")]
    path.write_text("\n".join(head + fn(data)) + "\n")


def edit_field(path: Path, line: int, field: int, value: str) -> None:
    """Sets one whitespace-separated field of the line-th data line."""
    def change(data):
        tokens = data[line].split()
        tokens[field] = value
        data[line] = " ".join(tokens)
        return data
    edit_lines(path, change)


def make_fifo(path: Path) -> None:
    remove(path)
    os.mkfifo(path)


def make_dir(path: Path) -> None:
    remove(path)
    path.mkdir(parents=True)


def link_to(path: Path, target: str) -> None:
    remove(path)
    os.symlink(target, path)


def remove(path: Path) -> None:
    if path.is_symlink() or path.is_file() or path.is_fifo():
        path.unlink()
    elif path.is_dir():
        import shutil
        shutil.rmtree(path)
