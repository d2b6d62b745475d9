"""cgv: conformal geometry videos, from Python.

3D motion (a mesh whose vertices move, the same faces every frame) coded as
H.264 video in a ``.cgv`` file, and back, with the metrics ``cgv eval``
reports. numpy in, numpy out::

    import cgv
    positions, faces, fps = cgv.read_motion("builtin:walk")   # (F, V, 3), (M, 3)
    data = cgv.encode(positions, faces, fps=fps, kbps=300)     # bytes of a .cgv file
    print(cgv.info(data)["kbps"])
    decoded, faces2 = cgv.decode(data)                         # the input's own mesh
    rms, worst = cgv.vertex_error(positions[5], decoded[5])
    print(rms / cgv.diagonal(positions))                      # relative to the diagonal

Long motions, one frame at a time (memory stays that of a frame)::

    cgv.encode_file("data/samba", output="samba.cgv", kbps=600)  # streamed into the file; its size
    reader = cgv.MotionReader("data/samba")          # len(reader), reader.faces, reader[i]
    for frame in cgv.Decoder(data):                   # (V, 3) arrays, in order; .seek(f)
        ...

Errors the library finds in its input are raised as :class:`cgv.Error` (a
``ValueError``), with a message that names the file and the problem.
"""

from ._native import (  # noqa: F401
    Decoder,
    Error,
    FORMAT_VERSION,
    MotionReader,
    __version__,
    decode,
    diagonal,
    encode,
    encode_file,
    info,
    kg_error,
    read_motion,
    surface_distance,
    vertex_error,
)

__all__ = [
    "Decoder",
    "Error",
    "FORMAT_VERSION",
    "MotionReader",
    "decode",
    "diagonal",
    "encode",
    "encode_file",
    "info",
    "kg_error",
    "read_motion",
    "surface_distance",
    "vertex_error",
]
