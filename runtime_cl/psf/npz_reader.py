"""Arrays of an uncompressed ``.npz`` from an untrusted file, read with bounds.

``np.load`` trusts what a file declares: a flipped byte can ask zlib to inflate a stored member,
make numpy allocate the shape a damaged ``.npy`` header claims, or reach the tokenizer numpy's
header parser uses. Here every member must be stored (``np.savez`` writes them so), its header
must declare a plain numeric dtype and no more bytes than the member holds, and the bytes are
read whole and checked against the zip's CRC. Any failure is one :class:`InputError`.
"""
from __future__ import annotations

import math
import zipfile

import numpy as np

from runtime_cl.errors import InputError

__all__ = ["read_npz"]

MAX_MEMBERS = 256     # a database holds 9 arrays plus its statistics


def _member(zf: zipfile.ZipFile, info: zipfile.ZipInfo, where: str) -> np.ndarray:
    name = info.filename
    if info.compress_type != zipfile.ZIP_STORED:
        raise InputError(f"{where}: array {name} is compressed (method {info.compress_type}); databases "
                         "store their arrays uncompressed")
    with zf.open(info) as fh:
        version = np.lib.format.read_magic(fh)
        read_header = {(1, 0): np.lib.format.read_array_header_1_0,
                       (2, 0): np.lib.format.read_array_header_2_0}.get(version)
        if read_header is None:
            raise InputError(f"{where}: array {name} has .npy version {version}")
        shape, fortran, dtype = read_header(fh)
        if dtype.hasobject or dtype.kind not in "biuf" or not all(isinstance(s, int) and s >= 0 for s in shape):
            raise InputError(f"{where}: array {name} declares dtype {dtype} and shape {shape}")
        nbytes = math.prod(shape) * dtype.itemsize
        if nbytes > info.file_size:
            raise InputError(f"{where}: array {name} declares {nbytes} bytes, the file holds {info.file_size}")
        data = fh.read(nbytes)
        fh.read()  # to the end, so zipfile checks the member's CRC
    if len(data) != nbytes:
        raise InputError(f"{where}: array {name} is truncated ({len(data)} of {nbytes} bytes)")
    return np.frombuffer(bytearray(data), dtype=dtype).reshape(shape, order="F" if fortran else "C")


def read_npz(fh, where: str) -> dict:
    """The arrays of the ``.npz`` open as ``fh`` (binary, seekable), by name without ``.npy``.

    Raises
    ------
    InputError
        Not a zip, a compressed or damaged member, a bad ``.npy`` header, too many members.
    """
    with zipfile.ZipFile(fh) as zf:
        infos = zf.infolist()
        if len(infos) > MAX_MEMBERS:
            raise InputError(f"{where}: {len(infos)} arrays, more than a database holds ({MAX_MEMBERS})")
        arrays = {}
        for info in infos:
            if not info.filename.endswith(".npy"):
                raise InputError(f"{where}: member {info.filename!r} is not a .npy array")
            arrays[info.filename[:-4]] = _member(zf, info, where)
    return arrays
