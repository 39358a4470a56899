"""VTK XML PolyData (``.vtp``): a small reader and a writer for meshes.

The reader handles ascii, inline binary and appended (base64 or raw)
DataArrays, UInt32/UInt64 headers and optional ``vtkZLibDataCompressor``
(xml.etree, base64, zlib). Meshes are written as inline binary DataArrays
(base64 of the little-endian values, UInt64 headers), so float64 coordinates
round-trip exactly and a million-vertex mesh is written in about a second
(ascii took ten). Polylines (:mod:`vesselgp.io.polyline`) are written in ascii.
"""
from __future__ import annotations

import base64
import re
import xml.etree.ElementTree as ET
import zlib
from pathlib import Path

import numpy as np

from ..errors import MeshReadError

__all__ = ["read_vtp", "write_vtp", "vtp_ascii_array", "vtp_binary_array", "FLOAT_FMT"]

#: Shortest format that round-trips every float64.
FLOAT_FMT = "%.17g"

_VTK_TYPES = {
    "Int8": "i1", "UInt8": "u1", "Int16": "i2", "UInt16": "u2",
    "Int32": "i4", "UInt32": "u4", "Int64": "i8", "UInt64": "u8",
    "Float32": "f4", "Float64": "f8",
}


def _b64chars(nbytes):
    return 4 * ((nbytes + 2) // 3)


def _b64(text, p):
    try:
        return base64.b64decode(text, validate=False)
    except (ValueError, TypeError) as exc:
        raise MeshReadError(f"{p}: corrupt base64 data in VTP file ({exc}); re-export it") from None


class _VtpDecoder:
    """Decodes VTK XML DataArrays of one file (ascii, binary, appended)."""

    def __init__(self, p, root, appended, app_encoding):
        self.p = p
        bo = root.get("byte_order", "LittleEndian")
        self.endian = "<" if bo == "LittleEndian" else ">"
        ht = root.get("header_type", "UInt32")
        if ht not in ("UInt32", "UInt64"):
            raise MeshReadError(f"{p}: unsupported VTP header_type {ht!r}; expected UInt32 or UInt64")
        self.hdt = np.dtype(self.endian + _VTK_TYPES[ht])
        comp = root.get("compressor")
        if comp not in (None, "", "vtkZLibDataCompressor"):
            raise MeshReadError(
                f"{p}: unsupported VTP compressor {comp!r}; re-save with zlib compression or none"
            )
        self.compressed = bool(comp)
        self.appended = appended
        self.app_encoding = app_encoding

    def array(self, da):
        p = self.p
        tname = da.get("type")
        if tname not in _VTK_TYPES:
            raise MeshReadError(f"{p}: unsupported VTP DataArray type {tname!r}")
        dt = np.dtype(self.endian + _VTK_TYPES[tname])
        fmt = da.get("format", "ascii")
        if fmt == "ascii":
            try:
                a = np.array((da.text or "").split(), dtype=np.float64)
            except ValueError as exc:
                raise MeshReadError(f"{p}: bad number in ascii VTP DataArray ({exc})") from None
            out = a.astype(dt.newbyteorder("=")) if dt.kind != "f" else a
        elif fmt == "binary":
            out = self._decode(re.sub(r"\s+", "", da.text or ""), dt, b64=True)
        elif fmt == "appended":
            if self.appended is None:
                raise MeshReadError(f"{p}: DataArray is 'appended' but the VTP has no AppendedData")
            off = int(da.get("offset", "0"))
            out = self._decode(self.appended[off:], dt, b64=self.app_encoding == "base64")
        else:
            raise MeshReadError(f"{p}: unknown VTP DataArray format {fmt!r}")
        ncomp = int(da.get("NumberOfComponents", "1"))
        return np.asarray(out).reshape(-1, ncomp) if ncomp > 1 else np.asarray(out).reshape(-1)

    def _decode(self, data, dt, b64):
        """Decode one binary block (header + payload), base64 text or raw bytes."""
        hs = self.hdt.itemsize
        p = self.p

        def take(pos, nbytes):
            """(bytes, next position) of one separately encoded chunk."""
            if not b64:
                return data[pos:pos + nbytes], pos + nbytes
            n = _b64chars(nbytes)
            return _b64(data[pos:pos + n], p)[:nbytes], pos + n

        if not self.compressed:
            if b64:
                first = _b64(data[:_b64chars(hs)], p)[:hs]
            else:
                first = data[:hs]
            if len(first) < hs:
                raise MeshReadError(f"{p}: truncated VTP binary DataArray; re-export the file")
            nbytes = int(np.frombuffer(first, self.hdt)[0])
            if b64:
                sep = data[_b64chars(hs) - 1:_b64chars(hs)] == "="
                if sep:  # header and payload base64-encoded separately
                    raw, _ = take(_b64chars(hs), nbytes)
                else:  # encoded together (VTK's default for uncompressed data)
                    raw = _b64(data[:_b64chars(hs + nbytes)], p)[hs:hs + nbytes]
            else:
                raw = data[hs:hs + nbytes]
            if len(raw) < nbytes:
                raise MeshReadError(f"{p}: truncated VTP binary DataArray; re-export the file")
            return np.frombuffer(raw, dt).copy()

        # compressed: header [nblocks, blocksize, lastsize, csize_1..csize_nblocks]
        first, _ = take(0, hs)
        if len(first) < hs:
            raise MeshReadError(f"{p}: truncated VTP compressed DataArray; re-export the file")
        nb = int(np.frombuffer(first, self.hdt)[0])
        head, pos = take(0, hs * (3 + nb))
        if len(head) < hs * (3 + nb):
            raise MeshReadError(f"{p}: truncated VTP compressed header; re-export the file")
        h = np.frombuffer(head, self.hdt).astype(np.int64)
        csizes = h[3:]
        payload, _ = take(pos, int(csizes.sum()))
        bounds = np.concatenate([[0], np.cumsum(csizes)])
        try:
            raw = b"".join(zlib.decompress(payload[a:b]) for a, b in zip(bounds[:-1], bounds[1:]))
        except zlib.error as exc:
            raise MeshReadError(f"{p}: corrupt zlib data in VTP file ({exc}); re-export it") from None
        return np.frombuffer(raw, dt).copy()


def _split_appended(raw):
    """Cut the AppendedData section out of the file so the rest parses as XML."""
    start = raw.find(b"<AppendedData")
    if start < 0:
        return raw, None, None
    tag_end = raw.find(b">", start)
    under = raw.find(b"_", tag_end)
    close = raw.rfind(b"</AppendedData>")
    if tag_end < 0 or under < 0 or close < under:
        return raw, None, None
    m = re.search(rb'encoding\s*=\s*"(\w+)"', raw[start:tag_end])
    enc = m.group(1).decode() if m else "raw"
    body = raw[under + 1:close]
    if enc == "base64":
        body = re.sub(rb"\s+", b"", body).decode("ascii")
    xml = raw[:tag_end + 1] + raw[close:]
    return xml, body, enc


def _triangulate(conn, offsets, p, what="polygon"):
    """Fan-triangulate polygons given by VTK connectivity + end offsets."""
    conn = np.asarray(conn, dtype=np.int64).reshape(-1)
    ends = np.asarray(offsets, dtype=np.int64).reshape(-1)
    if len(ends) and ends[0] == 0:  # VTK >= 9 in-memory style with a leading 0
        ends = ends[1:]
    starts = np.concatenate([[0], ends[:-1]])
    sizes = ends - starts
    if np.any(sizes < 3) or (len(ends) and ends[-1] > len(conn)):
        raise MeshReadError(
            f"{p}: VTP {what}s with fewer than 3 vertices or bad offsets; re-export the surface"
        )
    ntri = sizes - 2
    poly = np.repeat(np.arange(len(sizes)), ntri)
    j = np.arange(ntri.sum()) - np.repeat(np.cumsum(ntri) - ntri, ntri) + 1
    s = starts[poly]
    return np.c_[conn[s], conn[s + j], conn[s + j + 1]]


def read_vtp(p):
    """Parse a VTK XML PolyData file into ``(V, F, point_data)``."""
    raw = Path(p).read_bytes()
    xml, appended, enc = _split_appended(raw)
    try:
        root = ET.fromstring(xml)
    except ET.ParseError as exc:
        raise MeshReadError(f"{p}: not valid VTP XML ({exc}); re-export the file") from None
    if root.tag != "VTKFile" or root.get("type") != "PolyData":
        raise MeshReadError(
            f"{p}: not a VTK PolyData file (root {root.tag} type {root.get('type')}); "
            "export the surface as .vtp PolyData"
        )
    dec = _VtpDecoder(p, root, appended, enc)
    pieces = root.findall("PolyData/Piece")
    if not pieces:
        raise MeshReadError(f"{p}: VTP file has no PolyData Piece; re-export the surface")
    Vs, Fs, pdata, base = [], [], {}, 0
    for piece in pieces:
        npts = int(piece.get("NumberOfPoints", "0"))
        if int(piece.get("NumberOfStrips", "0")) > 0:
            raise MeshReadError(
                f"{p}: triangle strips are not supported; convert them to polygons first "
                "(e.g. vtkTriangleFilter) and save again"
            )
        pts = piece.find("Points/DataArray")
        if pts is None:
            raise MeshReadError(f"{p}: VTP Piece has no Points; re-export the surface")
        V = dec.array(pts).astype(np.float64).reshape(-1, 3)
        if len(V) != npts:
            raise MeshReadError(
                f"{p}: VTP Piece declares {npts} points but holds {len(V)}; the file is corrupt"
            )
        arrays = {da.get("Name"): da for da in piece.findall("Polys/DataArray")}
        npolys = int(piece.get("NumberOfPolys", "0"))
        if npolys > 0:
            if "connectivity" not in arrays or "offsets" not in arrays:
                raise MeshReadError(f"{p}: VTP Polys need 'connectivity' and 'offsets' arrays")
            F = _triangulate(dec.array(arrays["connectivity"]), dec.array(arrays["offsets"]), p)
        else:
            F = np.zeros((0, 3), dtype=np.int64)
        for da in piece.findall("PointData/DataArray"):
            name = da.get("Name")
            pdata.setdefault(name, []).append(dec.array(da))
        Vs.append(V)
        Fs.append(F + base)
        base += len(V)
    V = np.concatenate(Vs)
    F = np.concatenate(Fs)
    point_data = {k: np.concatenate(v) for k, v in pdata.items() if len(v) == len(pieces)}
    return V, F, point_data


def vtp_ascii_array(fh, vtype, name, A, ncomp=1, fmt=FLOAT_FMT, cols=None):
    comp = f' NumberOfComponents="{ncomp}"' if ncomp > 1 else ""
    fh.write(f'        <DataArray type="{vtype}" Name="{name}"{comp} format="ascii">\n'.encode())
    np.savetxt(fh, np.asarray(A).reshape(-1, cols or ncomp), fmt=fmt)
    fh.write(b"        </DataArray>\n")


_NUMPY_OF_VTK = {"Float64": "<f8", "Int64": "<i8", "UInt8": "u1"}


def vtp_binary_array(fh, vtype, name, A, ncomp=1):
    """One inline ``binary`` DataArray: base64 of the UInt64 byte count and the little-endian values.

    Exact (float64 as its 8 bytes) and about twenty times faster to write than ascii on large meshes.
    """
    data = np.ascontiguousarray(A, dtype=_NUMPY_OF_VTK[vtype]).tobytes()
    comp = f' NumberOfComponents="{ncomp}"' if ncomp > 1 else ""
    fh.write(f'        <DataArray type="{vtype}" Name="{name}"{comp} format="binary">\n'.encode())
    fh.write(base64.b64encode(np.uint64(len(data)).astype("<u8").tobytes() + data))
    fh.write(b"\n        </DataArray>\n")


def write_vtp(fh, V, F, colors, scalars):
    fh.write(b'<?xml version="1.0"?>\n'
             b'<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" '
             b'header_type="UInt64">\n  <PolyData>\n')
    fh.write(f'    <Piece NumberOfPoints="{len(V)}" NumberOfVerts="0" NumberOfLines="0" '
             f'NumberOfStrips="0" NumberOfPolys="{len(F)}">\n'.encode())
    if colors is not None or scalars:
        first = next(iter(scalars), None)
        attr = f' Scalars="{first}"' if first else ""
        fh.write(f"      <PointData{attr}>\n".encode())
        for name, a in scalars.items():
            vtp_binary_array(fh, "Float64", name, a)
        if colors is not None:
            vtp_binary_array(fh, "UInt8", "Colors", colors, colors.shape[1])
        fh.write(b"      </PointData>\n")
    fh.write(b"      <Points>\n")
    vtp_binary_array(fh, "Float64", "Points", V, 3)
    fh.write(b"      </Points>\n      <Polys>\n")
    vtp_binary_array(fh, "Int64", "connectivity", F)
    vtp_binary_array(fh, "Int64", "offsets", 3 * np.arange(1, len(F) + 1))
    fh.write(b"      </Polys>\n    </Piece>\n  </PolyData>\n</VTKFile>\n")
