"""The meshes of a replay: MuJoCo's compiled mesh geoms (a robot's links), simplified to a face
budget so that a page stays a few MB.

MuJoCo stores each mesh's vertices in the frame of the geoms that use it (it re-centres and
re-orients a mesh at compile time and moves the geoms' frames to match), so a mesh drawn at its
geom's world pose is where MuJoCo has it. The robots' visual meshes are large (Apollo's hold
1.4 million faces, 35 MB as base64): above the budget every mesh is simplified by **vertex
clustering** (Rossignac & Borrel 1993): the vertices are binned on a grid of cubes of one edge,
each bin's vertices become their mean, and the faces that collapse (two corners in one bin) or
repeat are dropped. The edge is the one that, for a surface of the meshes' total area ``A``,
leaves about ``2 A / edge^2`` faces, the budget (grown by 25 % steps until the count fits). Every
vertex moves by less than one cell diagonal, and a simplified mesh stays inside its original's
bounding box (a mean of points lies in their hull).
"""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_FACES", "mesh_arrays", "replay_meshes", "simplify"]

#: The meshes' faces, all together, in a replay page at most (about 6 MB of data).
MAX_FACES = 150_000


def mesh_arrays(model, mesh_id: int) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's mesh ``mesh_id``: vertices (V, 3) [m, in its geoms' frame] and faces (F, 3)
    (indices into those vertices)."""
    v0, nv = int(model.mesh_vertadr[mesh_id]), int(model.mesh_vertnum[mesh_id])
    f0, nf = int(model.mesh_faceadr[mesh_id]), int(model.mesh_facenum[mesh_id])
    return np.asarray(model.mesh_vert[v0 : v0 + nv], float), np.asarray(
        model.mesh_face[f0 : f0 + nf], np.int64
    )


def _area(verts: np.ndarray, faces: np.ndarray) -> float:
    a, b, c = (verts[faces[:, k]] for k in range(3))
    return 0.5 * float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


def simplify(verts: np.ndarray, faces: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertex clustering on a grid of cubes of edge ``cell`` [m] (module docstring); unused
    vertices dropped."""
    key = np.floor(verts / cell).astype(np.int64)
    key -= key.min(axis=0)
    span = key.max(axis=0) + 1
    _, inv, counts = np.unique((key[:, 0] * span[1] + key[:, 1]) * span[2] + key[:, 2], return_inverse=True,
                               return_counts=True)  # fmt: skip
    sums = np.column_stack([np.bincount(inv, weights=verts[:, k], minlength=counts.size) for k in range(3)])
    mean = sums / counts[:, None]
    f = inv[faces]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    s = np.sort(f, axis=1)
    n = np.int64(counts.size)
    _, first = np.unique((s[:, 0] * n + s[:, 1]) * n + s[:, 2], return_index=True)  # repeated faces
    f = f[np.sort(first)]
    used, f = np.unique(f, return_inverse=True)
    return mean[used], f.reshape(-1, 3)


def replay_meshes(model, mesh_ids, max_faces: int = MAX_FACES) -> tuple:
    """The meshes ``mesh_ids`` of ``model`` as (vertices float32 (V, 3), faces uint32 (F, 3))
    pairs, together at most ``max_faces`` faces (module docstring)."""
    if not (isinstance(max_faces, (int, np.integer)) and max_faces >= 100):
        from biped.errors import BipedError

        raise BipedError(f"max_mesh_faces must be a whole number >= 100, got {max_faces!r}")
    raw = [mesh_arrays(model, k) for k in mesh_ids]
    total = sum(len(f) for _, f in raw)
    out = raw
    if total > max_faces:
        cell = np.sqrt(2.0 * sum(_area(v, f) for v, f in raw) / max_faces)
        while True:
            out = [simplify(v, f, cell) for v, f in raw]
            if sum(len(f) for _, f in out) <= max_faces:
                break
            cell *= 1.25
    return tuple((v.astype(np.float32), f.astype(np.uint32)) for v, f in out)
