"""Image fields across a network link: encoded once by the node's server (the robot's side), decoded once
by each client (the reader's side), with established encoders: JPEG and PNG by OpenCV (`cv2.imencode` /
`cv2.imdecode`), lossless zstd by `zstandard`. Other fields, the timestamp among them, travel as they are.

A node says which of its fields may be compressed and how (`link_codecs()`: field -> {"codec", "quality"};
a camera's `codec`, `jpeg_quality` and `depth_codec` settings). "auto" is raw while the server serves this
machine only (loopback: no link to spare, and frames stay exact) and, once it serves other machines,
JPEG for colour images and zstd for everything else (depth: lossless). shm and thread never encode.

A coded record travels as one body (stream kind CODED):

    CODED_HEAD  total length (u32, this header included), number of coded fields (u8)
    ENTRY * n   field index in the layout (u16), codec id (u8), payload length (u32)
    rest        the record's bytes without the coded fields' bytes, in layout order
    payloads    the coded fields' payloads, in entry order

The decoder trusts nothing in it: it is checked against the client's own layout (which the handshake
matched to the server's), every decoded array must have its field's exact dtype and shape, and zstd is
decompressed with the field's size as the bound (no decompression bomb); a bad body is a `ValueError`.
"""

from __future__ import annotations

import struct
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from rio.errors import ConfigError
from rio.runtime.layout import Layout

CODECS = ("raw", "jpeg", "png", "zstd")
_IDS = {"jpeg": 1, "png": 2, "zstd": 3}
_NAMES = {v: k for k, v in _IDS.items()}
CODED_HEAD = struct.Struct("<IB")
ENTRY = struct.Struct("<HBI")
#: zstd level: 1 is the fastest, and depth compresses well at it.
ZSTD_LEVEL = 1


def _cv2() -> Any:
    try:
        import cv2
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("JPEG/PNG frames across a link need OpenCV: pip install 'rio-core[codecs]'") from e
    return cv2


def _zstd() -> Any:
    try:
        import zstandard
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("zstd frames across a link need zstandard: pip install 'rio-core[codecs]'") from e
    return zstandard


@dataclass
class CodecStats:
    """What a codec did, for benchmarks and the run summary: frames, bytes before and after, CPU time."""

    frames: int = 0
    raw_bytes: int = 0
    coded_bytes: int = 0
    cpu_s: float = 0.0

    @property
    def ratio(self) -> float:
        return self.raw_bytes / self.coded_bytes if self.coded_bytes else 0.0

    @property
    def cpu_ms_per_frame(self) -> float:
        return 1e3 * self.cpu_s / self.frames if self.frames else 0.0


def _colour(shape: tuple[int, ...]) -> bool:
    return len(shape) == 3 and shape[2] == 3


def resolve(node: str, layout: Layout, wanted: Mapping[str, Mapping[str, Any]], linked: bool
            ) -> dict[str, tuple[str, int]]:
    """field -> (codec, quality) for the fields to encode (raw ones left out). `linked`: the server serves
    other machines, so "auto" compresses. A codec a field cannot take is a ConfigError naming both."""
    out: dict[str, tuple[str, int]] = {}
    described = layout.describe()
    for field, spec in wanted.items():
        if field not in described:
            continue  # e.g. depth on a camera without it
        codec, quality = str(spec.get("codec", "auto")), int(spec.get("quality", 90))
        dt, shape = np.dtype(described[field][0]), tuple(described[field][1])
        if codec == "auto":
            codec = "raw" if not linked else ("jpeg" if dt == np.uint8 and _colour(shape) else "zstd")
        if codec not in CODECS:
            raise ConfigError(f"node '{node}': field '{field}': unknown codec '{codec}' (one of {list(CODECS)})")
        if codec == "jpeg" and not (dt == np.uint8 and (len(shape) == 2 or _colour(shape))):
            raise ConfigError(f"node '{node}': field '{field}' ({dt}, {shape}) cannot be JPEG (8-bit grey or "
                              "colour images only; use png or zstd for depth: lossless)")
        if codec == "png" and not (dt in (np.uint8, np.uint16) and (len(shape) == 2 or _colour(shape))):
            raise ConfigError(f"node '{node}': field '{field}' ({dt}, {shape}) cannot be PNG (8/16-bit images)")
        if not 1 <= quality <= 100:
            raise ConfigError(f"node '{node}': field '{field}': JPEG quality {quality} is not in 1..100")
        if codec != "raw":
            out[field] = (codec, quality)
    return out


class _Spans:
    """Byte ranges of a layout's fields: which bytes of a record are the coded fields and which the rest."""

    def __init__(self, layout: Layout, coded: list[int]):
        dt = layout.dtype
        assert dt.fields is not None
        ranges = sorted((dt.fields[layout.names[i]][1], dt.fields[layout.names[i]][1] + dt[layout.names[i]].itemsize)
                        for i in coded)
        self.rest: list[tuple[int, int]] = []
        pos = 0
        for lo, hi in ranges:
            if lo > pos:
                self.rest.append((pos, lo))
            pos = max(pos, hi)
        if pos < dt.itemsize:
            self.rest.append((pos, dt.itemsize))
        self.rest_bytes = sum(hi - lo for lo, hi in self.rest)


class RecordEncoder:
    """The server's end: a record (numpy structured scalar) -> one coded body."""

    def __init__(self, node: str, layout: Layout, codecs: dict[str, tuple[str, int]]):
        self.node, self.layout = node, layout
        self.fields = [(layout.names.index(f), f, codec, quality) for f, (codec, quality) in codecs.items()]
        self.fields.sort()
        self._spans = _Spans(layout, [i for i, *_ in self.fields])
        self.stats = CodecStats()
        self._zc: Any = _zstd().ZstdCompressor(level=ZSTD_LEVEL) if any(c == "zstd" for _, _, c, _ in
                                                                        self.fields) else None
        if any(c in ("jpeg", "png") for _, _, c, _ in self.fields):
            _cv2()

    def encode(self, rec: np.ndarray) -> bytes:
        t0 = time.thread_time()
        raw = memoryview(rec.tobytes()) if not isinstance(rec, (bytes, memoryview)) else memoryview(rec)
        entries, payloads = [], []
        for index, field, codec, quality in self.fields:
            payload = self._one(rec[field], codec, quality)
            entries.append(ENTRY.pack(index, _IDS[codec], len(payload)))
            payloads.append(payload)
        rest = b"".join(raw[lo:hi] for lo, hi in self._spans.rest)
        size = CODED_HEAD.size + ENTRY.size * len(entries) + len(rest) + sum(len(p) for p in payloads)
        body = b"".join([CODED_HEAD.pack(size, len(entries)), *entries, rest, *payloads])
        s = self.stats
        s.frames += 1
        s.raw_bytes += len(raw)
        s.coded_bytes += len(body)
        s.cpu_s += time.thread_time() - t0
        return body

    def _one(self, img: np.ndarray, codec: str, quality: int) -> bytes:
        if codec == "zstd":
            return self._zc.compress(np.ascontiguousarray(img).data)
        cv2 = _cv2()
        if codec == "jpeg":
            src = cv2.cvtColor(img, cv2.COLOR_RGB2BGR) if img.ndim == 3 else img  # JPEG's chroma is BGR's
            ok, buf = cv2.imencode(".jpg", src, [cv2.IMWRITE_JPEG_QUALITY, quality])
        else:  # png: lossless, so channel order comes back as it went
            ok, buf = cv2.imencode(".png", img, [cv2.IMWRITE_PNG_COMPRESSION, 1])
        if not ok:
            raise ValueError(f"node '{self.node}': OpenCV could not encode a {img.dtype} {img.shape} frame as {codec}")
        return buf.tobytes()


class RecordDecoder:
    """The client's end: one coded body -> the record's bytes, checked against this client's layout."""

    def __init__(self, layout: Layout):
        self.layout = layout
        self.stats = CodecStats()
        self._spans: dict[tuple[int, ...], _Spans] = {}
        self._zd: Any = None
        self._out = bytearray(layout.itemsize)

    def decode(self, body: bytes | memoryview) -> bytearray:
        """The record's bytes (a buffer this decoder reuses: copy it out before the next call)."""
        t0 = time.thread_time()
        body = memoryview(body)
        layout, names = self.layout, self.layout.names
        if len(body) < CODED_HEAD.size:
            raise ValueError("coded record: truncated")
        size, n = CODED_HEAD.unpack_from(body)
        if size != len(body):
            raise ValueError(f"coded record of {len(body)} bytes says {size}")
        pos = CODED_HEAD.size
        entries = []
        for _ in range(n):
            if pos + ENTRY.size > len(body):
                raise ValueError("coded record: truncated entries")
            index, codec, length = ENTRY.unpack_from(body, pos)
            pos += ENTRY.size
            if index >= len(names) or codec not in _NAMES:
                raise ValueError(f"coded record: field {index} or codec {codec} unknown")
            entries.append((index, _NAMES[codec], length))
        key = tuple(sorted(i for i, _, _ in entries))
        if len(set(key)) != len(key):
            raise ValueError("coded record: a field twice")
        spans = self._spans.get(key)
        if spans is None:
            spans = self._spans[key] = _Spans(layout, list(key))
        if pos + spans.rest_bytes + sum(length for _, _, length in entries) != len(body):
            raise ValueError("coded record: its parts do not add up to its length")
        out = self._out
        for lo, hi in spans.rest:
            out[lo:hi] = body[pos:pos + hi - lo]
            pos += hi - lo
        rec = np.frombuffer(out, dtype=layout.dtype, count=1)[0]
        for index, codec, length in entries:
            field = names[index]
            rec[field] = self._one(field, body[pos:pos + length], codec)
            pos += length
        s = self.stats
        s.frames += 1
        s.coded_bytes += len(body)
        s.raw_bytes += layout.itemsize
        s.cpu_s += time.thread_time() - t0
        return out

    def _one(self, field: str, payload: memoryview, codec: str) -> np.ndarray:
        dt, shape = self.layout.dtype[field].base, self.layout.dtype[field].shape
        if codec == "zstd":
            if self._zd is None:
                self._zd = _zstd().ZstdDecompressor()
            nbytes = int(np.prod(shape)) * dt.itemsize
            try:
                raw = self._zd.decompress(payload, max_output_size=nbytes)
            except Exception as e:  # zstd.ZstdError: a frame bigger than the field, or corrupt
                raise ValueError(f"field '{field}': bad zstd frame ({e})") from None
            if len(raw) != nbytes:
                raise ValueError(f"field '{field}': zstd frame of {len(raw)} bytes, the field has {nbytes}")
            return np.frombuffer(raw, dt).reshape(shape)
        cv2 = _cv2()
        flag = cv2.IMREAD_UNCHANGED if codec == "png" else (cv2.IMREAD_COLOR if len(shape) == 3 else
                                                             cv2.IMREAD_GRAYSCALE)
        img = cv2.imdecode(np.frombuffer(payload, np.uint8), flag)
        if img is None or img.dtype != dt or img.shape != shape:
            got = "nothing" if img is None else f"{img.dtype} {img.shape}"
            raise ValueError(f"field '{field}': {codec} frame decodes to {got}, the field is {dt} {shape}")
        return cv2.cvtColor(img, cv2.COLOR_BGR2RGB) if codec == "jpeg" and len(shape) == 3 else img


def encoder_for(node: Any, layout: Layout | None, linked: bool) -> RecordEncoder | None:
    """The encoder a node's server uses, or None when every field travels raw. `node.link_codecs()` (when
    the node has it) says what may be compressed."""
    wanted = getattr(node, "link_codecs", None)
    if layout is None or wanted is None:
        return None
    codecs = resolve(node.name, layout, wanted(), linked)
    return RecordEncoder(node.name, layout, codecs) if codecs else None
