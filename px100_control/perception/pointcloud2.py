"""
sensor_msgs/PointCloud2 bytes <-> numpy points and colours, without ROS.

A field is ``(name, offset, datatype, count)`` (sensor_msgs/PointField's members; datatype codes
as PointField: INT8 1 ... FLOAT64 8). :func:`decode` reads ``x``, ``y``, ``z`` (any float or
integer type, any order and offset) and the colour from a packed ``rgb`` / ``rgba`` field
(float32 or uint32 holding 0x00RRGGBB, as PCL writes it) or from separate ``r``, ``g``, ``b``
fields; without colour fields the colours are 0. Little-endian only: a big-endian cloud is
refused. :func:`encode` writes PCL's XYZRGB layout (x, y, z float32 at 0, 4, 8; rgb float32 at
16; point_step 32). Units: whatever the cloud holds (metres in ROS); colours 0..255.
"""
from typing import List, Sequence, Tuple

import numpy as np
from px100_control.errors import InvalidInputError

#: PointField datatype code -> numpy little-endian dtype
DATATYPES = {1: '<i1', 2: '<u1', 3: '<i2', 4: '<u2', 5: '<i4', 6: '<u4', 7: '<f4', 8: '<f8'}
FLOAT32 = 7
#: PCL's XYZRGB layout: (name, offset, datatype, count)
XYZRGB_FIELDS = (('x', 0, FLOAT32, 1), ('y', 4, FLOAT32, 1), ('z', 8, FLOAT32, 1),
                 ('rgb', 16, FLOAT32, 1))
XYZRGB_STEP = 32

Field = Tuple[str, int, int, int]


def _layout(fields: Sequence[Field], point_step: int) -> dict:
    """Return {name: (offset, dtype)} of the fields, checked against point_step."""
    layout = {}
    for name, offset, datatype, count in fields:
        if datatype not in DATATYPES:
            raise InvalidInputError(f"field '{name}': unknown datatype {datatype} "
                                    f'(PointField codes 1..8)')
        size = np.dtype(DATATYPES[datatype]).itemsize
        if offset < 0 or offset + size * max(count, 1) > point_step:
            raise InvalidInputError(f"field '{name}' (offset {offset}, {size} bytes) does not "
                                    f'fit in point_step {point_step}')
        layout[name] = (offset, DATATYPES[datatype])
    return layout


def decode(fields: Sequence[Field], point_step: int, data: bytes, width: int, height: int,
           row_step: int, is_bigendian: bool = False) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return (points (N, 3) float64, colours (N, 3) uint8) of a PointCloud2's contents.

    N = width * height; padding at the end of a row (row_step > width * point_step) is
    skipped. NaN points are kept (the filter drops non-finite points).

    :raises InvalidInputError: big-endian, no x/y/z field, a field outside point_step, or
        fewer bytes than width, height and row_step say
    """
    if is_bigendian:
        raise InvalidInputError('big-endian PointCloud2 is not supported (is_bigendian true)')
    if point_step <= 0 and width * height > 0:
        raise InvalidInputError(f'point_step must be > 0, got {point_step}')
    layout = _layout(fields, point_step)
    missing = [n for n in 'xyz' if n not in layout]
    if missing:
        raise InvalidInputError(f'PointCloud2 has no field {missing} (fields: '
                                f'{sorted(layout)})')
    n = width * height
    if n == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.uint8)
    if row_step < width * point_step or len(data) < row_step * (height - 1) + width * point_step:
        raise InvalidInputError(f'PointCloud2 data has {len(data)} bytes; width {width}, height '
                                f'{height}, point_step {point_step}, row_step {row_step} need '
                                f'{row_step * height}')
    wanted = [k for k in ('x', 'y', 'z', 'rgb', 'rgba', 'r', 'g', 'b') if k in layout]
    formats = ['<u4' if k in ('rgb', 'rgba') else layout[k][1] for k in wanted]
    record = np.dtype({'names': wanted, 'formats': formats, 'itemsize': point_step,
                       'offsets': [layout[k][0] for k in wanted]})
    if row_step == width * point_step:
        rec = np.frombuffer(data, dtype=record, count=n)
    else:                             # padded rows: one view per row
        rec = np.concatenate([np.frombuffer(data, dtype=record, count=width,
                                            offset=r * row_step) for r in range(height)])
    points = np.column_stack([rec[k].astype(np.float64) for k in 'xyz'])
    return points, _colours(rec, n)


def _colours(rec: np.ndarray, n: int) -> np.ndarray:
    """Return the (N, 3) uint8 colours of a packed rgb/rgba field or r, g, b fields (else 0)."""
    names = rec.dtype.names
    packed = 'rgb' if 'rgb' in names else ('rgba' if 'rgba' in names else None)
    if packed is not None:
        word = rec[packed]
        return np.column_stack([(word >> 16) & 255, (word >> 8) & 255,
                                word & 255]).astype(np.uint8)
    if all(k in names for k in 'rgb'):
        return np.column_stack([rec[k] for k in 'rgb']).astype(np.uint8)
    return np.zeros((n, 3), dtype=np.uint8)


def encode(points: np.ndarray, colors: np.ndarray = None) -> Tuple[List[Field], int, bytes]:
    """
    Return (fields, point_step, data) of an unorganised XYZRGB cloud (PCL's layout).

    :param points: (N, 3) [m]
    :param colors: (N, 3) 0..255, or None for black
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = len(points)
    colors = np.zeros((n, 3)) if colors is None else np.asarray(colors).reshape(-1, 3)
    if len(colors) != n:
        raise InvalidInputError(f'{n} points but {len(colors)} colours')
    rgb = np.clip(np.rint(colors), 0, 255).astype(np.uint32)
    out = np.zeros((n, XYZRGB_STEP), dtype=np.uint8)
    out[:, 0:12] = points.astype('<f4').view(np.uint8).reshape(n, 12)
    word = (rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2]
    out[:, 16:20] = word.astype('<u4').view(np.uint8).reshape(n, 4)
    return list(XYZRGB_FIELDS), XYZRGB_STEP, out.tobytes()
