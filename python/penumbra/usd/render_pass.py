"""A UsdRenderPass's collections (``penumbra-record -rp``), as each prim renders under them.

* ``prune`` (empty unless authored): prims removed from the render, with their descendants;
* ``renderVisibility`` (everything unless authored): prims outside it render nothing;
* ``cameraVisibility`` (everything unless authored): prims outside it are not seen by camera
  rays, but still cast shadows, show in reflections and light the scene;
* ``matte`` (empty unless authored): holdouts: camera rays that meet them end there, adding no
  colour and no alpha, so they hide what is behind them in the image.

Membership is evaluated with ``Usd.CollectionAPI``'s membership queries (includes, excludes,
expansion rules and membership expressions alike) on the paths of the prims as composed; for
instanced geometry, the path of the native instance or point instancer that places it.
"""

from __future__ import annotations

from dataclasses import dataclass

from pxr import Sdf, Usd, UsdRender

from ..errors import SceneError
from .stage import stage_name


@dataclass(frozen=True)
class PassVisibility:
    """How a render pass shows one prim (when it is rendered at all); the other rays' view of
    it comes from its own primvars (ray_visibility.py), as core.set_pass_visibility takes it."""

    camera: bool = True
    matte: bool = False
    shadow: bool = True
    diffuse: bool = True
    glossy: bool = True
    transmission: bool = True


SHOWN = PassVisibility()
"""A prim that no collection of the pass changes."""

HIDING_RAYS = ("shadow", "diffuse", "glossy", "transmission")
"""The rays other than the camera's that an object may be hidden from (its own primvars)."""


def set_pass_visibility(core, prim_id: str, shown: PassVisibility) -> None:
    """Send ``shown`` to the mesh, points, curves or instancer ``prim_id`` of ``core``."""
    core.set_pass_visibility(
        prim_id,
        shown.camera,
        shown.matte,
        shadow=shown.shadow,
        diffuse=shown.diffuse,
        glossy=shown.glossy,
        transmission=shown.transmission,
    )


class RenderPassCollections:
    """The membership queries of one render pass's collections."""

    def __init__(self, render_pass: UsdRender.Pass):
        prim = render_pass.GetPrim()
        self._queries = {
            name: Usd.CollectionAPI(prim, name).ComputeMembershipQuery()
            for name in ("prune", "renderVisibility", "cameraVisibility", "matte")
        }

    def rendered(self, path: Sdf.Path) -> bool:
        """Whether the prim at ``path`` renders at all (not pruned, render-visible)."""
        return not self._queries["prune"].IsPathIncluded(path) and self._queries[
            "renderVisibility"
        ].IsPathIncluded(path)

    def visibility(self, path: Sdf.Path) -> PassVisibility:
        """How camera rays treat the prim at ``path`` (which :meth:`rendered` renders)."""
        return PassVisibility(
            camera=self._queries["cameraVisibility"].IsPathIncluded(path),
            matte=self._queries["matte"].IsPathIncluded(path),
        )


def find_render_pass(stage: Usd.Stage, pass_path: str | Sdf.Path) -> UsdRender.Pass:
    """The UsdRenderPass at ``pass_path``; :class:`SceneError` naming it when it is none."""
    text = str(pass_path)
    render_pass = (
        UsdRender.Pass(stage.GetPrimAtPath(text))
        if Sdf.Path.IsValidPathString(text) and text.startswith("/")
        else None
    )
    if not render_pass:
        raise SceneError(f"{stage_name(stage)}: {text} is not a RenderPass prim")
    return render_pass


def render_pass_collections(stage: Usd.Stage, pass_path: str | Sdf.Path) -> RenderPassCollections:
    """The collections of the UsdRenderPass at ``pass_path`` (see :func:`find_render_pass`)."""
    return RenderPassCollections(find_render_pass(stage, pass_path))
