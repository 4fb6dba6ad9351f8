"""Batched pushes to the render delegate: the scene delegate queues the mesh data, transforms,
visibilities and material bindings of one sync and sends each kind in one ``_core`` call
(docs/architecture.md, "Scene delegate"), instead of paying a binding call per prim and
aspect. World transforms are checked here, all at once, before they reach the delegate.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .._core import MeshRecord

CHUNK = 1024
"""Meshes (and transforms) queued at most before they are sent: the queued arrays (and the USD
values they view) stay bounded however many meshes a sync pushes, for one call per thousand
meshes. The scene delegate reads plain meshes and transforms in chunks of this size too."""

MAX_COORDINATE = 1e18
"""Beyond this distance from the origin (scene units) single-precision ray tracing cannot
place geometry: Embree drops it."""


class CoreBatch:
    """Queues setter calls for ``core`` (a ``penumbra._core.RenderDelegate``) until
    :meth:`send`. Only what does not depend on call order is queued: every queued setter
    replaces one aspect of one prim, and prims are inserted before their data is queued."""

    def __init__(self, core, warn: Callable[[str], None]) -> None:
        self.core = core
        self._warn = warn
        self._meshes: list[MeshRecord] = []
        self._transforms: tuple[list[str], list[np.ndarray]] = ([], [])
        self._visible: tuple[list[str], list[bool]] = ([], [])
        self._materials: tuple[list[str], list[str]] = ([], [])
        self._subset_materials: list[tuple[str, list[tuple[str, np.ndarray]]]] = []
        self._not_lights: list[str] = []  # meshes without UsdLuxMeshLightAPI: most of them
        self.mesh_lights: set[str] = set()
        """The meshes made lights (UsdLuxMeshLightAPI) through this batch."""

    # The setters mesh.py calls (as on the delegate itself).

    def set_mesh(
        self,
        path: str,
        *,
        face_vertex_counts: np.ndarray,
        face_vertex_indices: np.ndarray,
        left_handed: bool,
        subdivision_scheme: str,
        points: np.ndarray,
        double_sided: bool,
        display_color: np.ndarray,
        display_color_interpolation: str,
        normals: np.ndarray,
        normals_interpolation: str,
        primvars: dict,
    ) -> None:
        self.add_mesh(
            MeshRecord(
                path,
                face_vertex_counts=face_vertex_counts,
                face_vertex_indices=face_vertex_indices,
                left_handed=left_handed,
                subdivision_scheme=subdivision_scheme,
                points=points,
                double_sided=double_sided,
                display_color=display_color,
                display_color_interpolation=display_color_interpolation,
                normals=normals,
                normals_interpolation=normals_interpolation,
                primvars=primvars,
            )
        )

    def add_mesh(self, mesh: MeshRecord) -> None:
        """Queue ``set_mesh``'s arguments as one ``set_meshes`` record."""
        self._meshes.append(mesh)
        if len(self._meshes) >= CHUNK:
            self.core.set_meshes(self._meshes)
            self._meshes = []

    def set_mesh_subdivision_tags(self, path: str, **tags) -> None:
        self.core.set_mesh_subdivision_tags(path, **tags)

    def set_mesh_light(self, path: str, enabled: bool, **params) -> None:
        if enabled:
            self.core.set_mesh_light(path, enabled, **params)
            self.mesh_lights.add(path)
        else:
            self._not_lights.append(path)

    # The scene delegate's own.

    def set_transform(self, path: str, matrices: np.ndarray) -> None:
        """Queue local-to-world ``matrices`` ((4, 4) or (K, 4, 4)) of prim ``path``."""
        self._transforms[0].append(path)
        self._transforms[1].append(matrices)

    def set_transforms(self, paths: list[str], matrices: list[np.ndarray]) -> None:
        """:meth:`set_transform` for each of ``paths`` (sent when a chunk's worth is queued)."""
        self._transforms[0].extend(paths)
        self._transforms[1].extend(matrices)
        if len(self._transforms[0]) >= CHUNK:
            self._send_transforms()

    def set_visible(self, path: str, visible: bool) -> None:
        self._visible[0].append(path)
        self._visible[1].append(visible)

    def set_mesh_material(self, path: str, material_id: str) -> None:
        self._materials[0].append(path)
        self._materials[1].append(material_id)

    def set_subset_materials(self, path: str, subsets: list[tuple[str, np.ndarray]]) -> None:
        """Queue mesh ``path``'s per-face bindings: (material id, faces) for each subset."""
        self._subset_materials.append((path, subsets))

    def send(self) -> None:
        """Send what was queued (mesh data first) and forget it."""
        if self._meshes:
            self.core.set_meshes(self._meshes)
            self._meshes = []
        if self._not_lights:
            self.core.disable_mesh_lights(self._not_lights)
            self._not_lights = []
        if self._transforms[0]:
            self._send_transforms()
        if self._visible[0]:
            self.core.set_visibilities(*self._visible)
            self._visible = ([], [])
        if self._materials[0]:
            self.core.set_mesh_materials(*self._materials)
            self._materials = ([], [])
        for path, subsets in self._subset_materials:
            self.core.set_subset_materials(path, subsets)
        self._subset_materials = []

    def _send_transforms(self) -> None:
        self._check_transforms(*self._transforms)
        self.core.set_transforms(*self._transforms)
        self._transforms = ([], [])

    def _check_transforms(self, paths: list[str], matrices: list[np.ndarray]) -> None:
        """Warn about each prim whose world transform is unusable (the delegate then does not
        render it); the usual static (4, 4) matrices are checked all together."""
        problems: list[str | None] = [None] * len(matrices)
        static = [n for n, m in enumerate(matrices) if m.ndim == 2]
        if static:
            stacked = np.stack([matrices[n] for n in static])
            for n, problem in zip(static, _problems(stacked)):
                problems[n] = problem
        for n, m in enumerate(matrices):
            if m.ndim == 3:  # motion samples: one verdict over all of them
                problems[n] = _problems(m.reshape(1, -1, 4))[0]
        for path, problem in zip(paths, problems):
            if problem:
                self._warn(f"{path}: the world transform {problem}; the prim is not rendered")


def _problems(matrices: np.ndarray) -> list[str | None]:
    """What makes each of (N, 4·K, 4) stacked local-to-world matrices unusable, or ``None``."""
    finite = np.isfinite(matrices).all(axis=(1, 2))
    far = np.abs(matrices.reshape(len(matrices), -1, 4, 4)[:, :, 3, :3]).max(axis=(1, 2))
    far = far > MAX_COORDINATE
    if finite.all() and not far.any():
        return [None] * len(matrices)
    return [
        None
        if ok and not distant
        else "is not finite (a NaN or infinity in an xformOp)"
        if not ok
        else f"translates it beyond {MAX_COORDINATE:g} units, where precision runs out"
        for ok, distant in zip(finite, far)
    ]
