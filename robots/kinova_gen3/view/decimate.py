"""Decimates Kinova's Gen3 link meshes for the plan viewer (`omcbsa view`).

Run at development time; its output (the binary STL files beside this script) is committed,
so neither CI nor users need it:

    python3 -m venv /tmp/dec && /tmp/dec/bin/pip install fast-simplification==0.1.11 numpy
    /tmp/dec/bin/python robots/kinova_gen3/view/decimate.py /work/shared/robots/kinova_gen3/meshes

Kinova's meshes are under the BSD licence in robots/kinova_gen3/LICENSE.
"""

import pathlib
import struct
import sys

import fast_simplification
import numpy as np

# Triangles kept per link: enough for the silhouette, small enough for a page under 5 MB.
TARGET_TRIANGLES = 2500
LINKS = [
    "base_link",
    "shoulder_link",
    "half_arm_1_link",
    "half_arm_2_link",
    "forearm_link",
    "spherical_wrist_1_link",
    "spherical_wrist_2_link",
    "bracelet_no_vision_link",
]


def read_stl(path):
    data = path.read_bytes()
    (n,) = struct.unpack_from("<I", data, 80)
    # 50-byte records: 12 floats then a 2-byte attribute.
    rec = np.frombuffer(data[84 : 84 + 50 * n], dtype=np.uint8).reshape(n, 50)
    tris = rec[:, 12:48].copy().view("<f4").reshape(n, 3, 3)
    points, faces = np.unique(tris.reshape(-1, 3), axis=0, return_inverse=True)
    return points.astype(np.float64), faces.reshape(-1, 3)


def write_stl(path, points, faces):
    tris = points[faces].astype("<f4")
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = (normals / np.where(length > 0, length, 1)).astype("<f4")
    out = bytearray(b"omcbsa viewer: decimated Kinova Gen3 mesh (BSD, see LICENSE)".ljust(80))
    out += struct.pack("<I", len(faces))
    for nrm, tri in zip(normals, tris):
        out += nrm.tobytes() + tri.tobytes() + b"\0\0"
    path.write_bytes(bytes(out))


def main(src):
    here = pathlib.Path(__file__).parent
    for link in LINKS:
        points, faces = read_stl(pathlib.Path(src) / f"{link}.STL")
        ratio = max(0.0, 1.0 - TARGET_TRIANGLES / len(faces))
        p, f = fast_simplification.simplify(points, faces, target_reduction=ratio)
        write_stl(here / f"{link}.stl", p, f)
        print(f"{link}: {len(faces)} -> {len(f)} triangles")


if __name__ == "__main__":
    main(sys.argv[1])
