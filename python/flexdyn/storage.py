"""Results files that a crash cannot corrupt: append-only NetCDF classic (64-bit offset).

Why not the netCDF4 (HDF5) library for writing: HDF5 rewrites metadata all over the file as it
grows, so a kill, a power loss or a full disk mid-write can leave a file that no longer opens.
The NetCDF classic format (CDF-2, https://docs.unidata.ucar.edu/netcdf-c/current/file_format_specifications.html)
has one fixed header and then records appended one after another; the only field that changes
as the file grows is `numrecs`, four bytes in the header. Each flush therefore

1. appends the new records after the last complete one and syncs them to disk, then
2. overwrites `numrecs` and syncs again.

Whatever stops the run between or during those writes, the header's `numrecs` counts only
records that are completely on disk, so the file opens (with xarray, netCDF4, ncdump, ParaView)
with every sample up to the last flush. The header is written once with room to spare, so the
final attributes (completed, statistics, warnings) are written in place at the end without
moving data.
"""

from __future__ import annotations

import contextlib
import os
import struct
from pathlib import Path

import numpy as np

from . import _core

_MAGIC = b"CDF\x02"
_DIMENSION, _VARIABLE, _ATTRIBUTE = 0x0A, 0x0B, 0x0C
_CHAR, _INT, _DOUBLE = 2, 4, 6
#: Header room kept for the attributes written when the run ends (statistics, warnings).
_HEADER_SPARE = 64 * 1024
#: Longest warnings text stored in the file's attributes (all warnings are also reported).
_MAX_WARNINGS_TEXT = 32 * 1024


class OutputError(_core.FlexdynError, OSError):
    """The results file cannot be created or written (missing folder, read-only, disk full).
    An OSError too, with its `errno`."""

    def __str__(self):
        return str(self.args[1]) if len(self.args) > 1 else super().__str__()


def _pad4(b: bytes) -> bytes:
    return b + b"\0" * (-len(b) % 4)


def _name(s: str) -> bytes:
    raw = s.encode("utf-8")
    return struct.pack(">i", len(raw)) + _pad4(raw)


def _attribute(name: str, value) -> bytes:
    if isinstance(value, (bool, np.bool_)):
        value = int(value)
    if isinstance(value, (int, np.integer)) and -(2**31) <= int(value) < 2**31:
        return _name(name) + struct.pack(">ii", _INT, 1) + struct.pack(">i", int(value))
    if isinstance(value, (int, float, np.integer, np.floating)):
        return _name(name) + struct.pack(">ii", _DOUBLE, 1) + struct.pack(">d", float(value))
    raw = str(value).encode("utf-8")
    return _name(name) + struct.pack(">ii", _CHAR, len(raw)) + _pad4(raw)


def _attributes(attrs: dict) -> bytes:
    if not attrs:
        return b"\0" * 8
    return struct.pack(">ii", _ATTRIBUTE, len(attrs)) + b"".join(_attribute(k, v) for k, v in attrs.items())


class ArrayVariable:
    """A variable beyond the plain channels: a record variable with extra dimensions
    (`data` None: its values are columns of each record) or a fixed one written once
    (`data`: float64, int32, or a list of strings stored as a UTF-8 char array)."""

    def __init__(self, name, dims, attrs=None, data=None):
        self.name, self.dims, self.attrs = name, tuple(dims), dict(attrs or {})
        self.data = data


def _fixed_bytes(var: ArrayVariable, sizes: dict) -> tuple[int, bytes]:
    """A fixed variable's nc_type and its data, padded to 4 bytes."""
    data = var.data
    if isinstance(data, (list, tuple)) and (not data or isinstance(data[0], str)):
        width = sizes[var.dims[-1]]
        raw = b"".join(s.encode("utf-8").ljust(width, b"\0") for s in data)
        return _CHAR, _pad4(raw)
    arr = np.asarray(data)
    if arr.dtype.kind in "iub":
        return _INT, arr.astype(">i4").tobytes()
    return _DOUBLE, arr.astype(">f8").tobytes()


class AppendOnlyNetcdf:
    """A NetCDF classic file with one unlimited dimension and one f8 variable per channel,
    plus optional `arrays` (see ArrayVariable) over `dimensions` (name → size).

    `path` is created (or replaced by a new file: whoever still reads the old one keeps
    reading it); `names` are the channels and `units` their units or, as dicts, all their
    attributes (`dim_units` likewise for the record dimension's coordinate); `attrs` global
    attributes. `append(times, values[n, columns])` adds records durably, the columns being
    the channels and then each record array flattened, in order; `finish(attrs)` adds final
    global attributes. Raises OutputError naming the file if it cannot be written.
    """

    def __init__(self, path, names, units, attrs, dim="time", dim_units="s", arrays=(), dimensions=None):
        self.path = Path(path)
        self.dim, self.dim_units = dim, dim_units
        self.names, self.units = [dim, *names], [dim_units, *units]
        self.dimensions = {dim: 0, **(dimensions or {})}
        self.dim_ids = {d: k for k, d in enumerate(self.dimensions)}
        self.arrays = list(arrays)
        self.fixed = [v for v in self.arrays if v.data is not None]
        self.record_arrays = [v for v in self.arrays if v.data is None]
        self.attrs = dict(attrs)
        self.records = 0
        self.fixed_data = [_fixed_bytes(v, self.dimensions) for v in self.fixed]
        # Header size with the spare room: the data start after it, for good.
        self.data_start = len(self._header(0, self.attrs)) + _HEADER_SPARE
        self.record_start = self.data_start + sum(len(b) for _, b in self.fixed_data)
        self.record_bytes = 8 * len(self.names) + sum(self._vsize(v) for v in self.record_arrays)
        try:
            # A new file, not the old one truncated: a dataset still reading the last run's
            # file (lazily) keeps its data rather than seeing this run's appear under it.
            with contextlib.suppress(FileNotFoundError, IsADirectoryError):
                os.unlink(self.path)
            self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o644)
        except OSError as e:
            raise OutputError(e.errno, f"cannot create the results file {self.path}: {e.strerror}") from e
        try:
            header = self._header(0, self.attrs)
            fixed = b"".join(b for _, b in self.fixed_data)
            self._write_all(header + b"\0" * (self.data_start - len(header)) + fixed, 0)
            os.fsync(self.fd)
        except OSError as e:
            os.close(self.fd)
            raise OutputError(e.errno, f"cannot write the results file {self.path}: {e.strerror}") from e

    def _vsize(self, var: ArrayVariable) -> int:
        """Bytes of one record of a record array (f8)."""
        return 8 * int(np.prod([self.dimensions[d] for d in var.dims[1:]]))

    def _header(self, records: int, attrs: dict) -> bytes:
        out = [_MAGIC, struct.pack(">i", records)]
        out.append(struct.pack(">ii", _DIMENSION, len(self.dimensions)))
        out.extend(_name(d) + struct.pack(">i", n) for d, n in self.dimensions.items())
        out.append(_attributes(attrs))
        out.append(struct.pack(">ii", _VARIABLE, len(self.names) + len(self.arrays)))
        start = getattr(self, "data_start", 0)
        for var, (nc_type, data) in zip(self.fixed, getattr(self, "fixed_data", [])):
            ids = [self.dim_ids[d] for d in var.dims]
            out.append(_name(var.name) + struct.pack(f">i{len(ids)}i", len(ids), *ids))
            out.append(_attributes(var.attrs) + struct.pack(">iiq", nc_type, len(data), start))
            start += len(data)
        offset = getattr(self, "record_start", 0)
        for n, u in zip(self.names, self.units):
            var_attrs = u if isinstance(u, dict) else {"units": u}
            out.append(_name(n) + struct.pack(">ii", 1, 0) + _attributes(var_attrs))
            # nc_type, vsize (one record of this variable), begin (64-bit offset)
            out.append(struct.pack(">iiq", _DOUBLE, 8, offset))
            offset += 8
        for var in self.record_arrays:
            ids = [self.dim_ids[d] for d in var.dims]
            out.append(_name(var.name) + struct.pack(f">i{len(ids)}i", len(ids), *ids))
            size = self._vsize(var)
            out.append(_attributes(var.attrs) + struct.pack(">iiq", _DOUBLE, size, offset))
            offset += size
        return b"".join(out)

    def _write_all(self, data: bytes, offset: int) -> int:
        """Writes `data` at `offset`; on an error, the exception carries `.written` bytes."""
        view, done = memoryview(data), 0
        while view:
            try:
                n = os.pwrite(self.fd, view, offset + done)
            except OSError as e:
                e.written = done
                raise
            view, done = view[n:], done + n
        return done

    def _commit(self, records: int):
        """Makes `records` records count: synced data first, then the header's count."""
        os.fsync(self.fd)
        os.pwrite(self.fd, struct.pack(">i", records), 4)
        os.fsync(self.fd)
        self.records = records

    def append(self, times, values):
        """Adds len(times) records; on return they are on disk and counted in the header. If
        the disk fills up, the records that did fit are kept and OutputError says how many
        the file holds."""
        m = len(times)
        if m == 0:
            return
        rows = np.empty((m, self.record_bytes // 8), dtype=">f8")
        rows[:, 0] = times
        rows[:, 1:] = values
        try:
            self._write_all(rows.tobytes(), self.record_start + self.records * self.record_bytes)
            self._commit(self.records + m)
        except OSError as e:
            fitted = getattr(e, "written", 0) // self.record_bytes
            with contextlib.suppress(OSError):
                if fitted:
                    self._commit(self.records + fitted)
            raise OutputError(
                e.errno,
                f"cannot write to the results file {self.path}: {e.strerror}; "
                f"it holds the {self.records} samples written before",
            ) from e

    def finish(self, attrs: dict):
        """Adds `attrs` to the global attributes, in the header's spare room (nothing moves)."""
        merged = {**self.attrs, **attrs}
        if len(str(merged.get("warnings", ""))) > _MAX_WARNINGS_TEXT:
            text = merged["warnings"]
            merged["warnings"] = (
                text[:_MAX_WARNINGS_TEXT] + f"\n… ({len(text) - _MAX_WARNINGS_TEXT} more characters)"
            )
        header = self._header(self.records, merged)
        if len(header) > self.data_start:
            raise OutputError(0, f"final attributes of {self.path} do not fit its header")
        try:
            self._write_all(header, 0)
            os.fsync(self.fd)
        except OSError as e:
            raise OutputError(e.errno, f"cannot finish the results file {self.path}: {e.strerror}") from e
        self.attrs = merged

    def close(self):
        """Closes the file (what it holds stays valid: every append was synced)."""
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
